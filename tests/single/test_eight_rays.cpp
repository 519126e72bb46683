// The eight-lane camera march (MarchEightRays.cpp) against the scalar one it replaces
// (marchSingle, one ray at a time): same samples, same estimator, so the same answer per ray.
// The one place they may part: a sample within float rounding of a brick face is placed by the
// scalar walk's DDA in the brick the segment belongs to, by the lanes in the brick its computed
// position falls in. Where one side of that face is an unallocated brick (density there reads
// as zero), the sample counts in one march and not in the other. Such rays are rare (a sample
// would have to land within ~1e-6 voxels of a face); the test counts them and bounds them.
#include "../render/SceneBuilders.h"
#include "ProbeRays.h"

#include "render/RenderContext.h"
#include "single/MarchEightRays.h"
#include "single/SingleScatter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace nimbus;
using namespace nimbus::test;

namespace {

Scene greyCloudKeyLight(float step)
{
    Scene s = emptyScene(64, 48);
    s.volumes.push_back(proceduralCloud(0.05, splat(6.0f), splat(0.3f), 0.5f));
    s.lights.push_back(distantLight("key", make_float3(0.4f, -1.0f, -0.6f), splat(3.0f)));
    s.render.step = step;
    s.render.seed = 5;
    return s;
}

// Marches every ray once alone (marchSingle) and once in batches (marchSingleRays); returns
// how many rays differ by more than `tolerance` relative in L1, transmittance or depth.
int raysThatDiffer(const RenderContext& ctx, const std::vector<Ray>& rays, int batch, float tolerance,
                   double* worstAgreeing)
{
    const size_t stride = 3 * ctx.lights.size();
    int differing = 0;
    *worstAgreeing = 0.0;
    for (size_t first = 0; first < rays.size(); first += size_t(batch)) {
        const int n = int(std::min(rays.size() - first, size_t(batch)));
        std::vector<CameraSample> batchOut;
        std::vector<float> batchLight;
        marchBatch(ctx, rays, first, n, 7, batchOut, batchLight);
        for (int i = 0; i < n; ++i) {
            NbRng rng = nbRngStart(7, nb_uint(first) + nb_uint(i), 0);
            CameraSample alone;
            std::vector<float> light(stride, 0.0f);
            marchSingle(ctx, rays[first + size_t(i)].o, rays[first + size_t(i)].d, rng, alone, light.data());
            const CameraSample& b = batchOut[size_t(i)];
            auto rel = [](float a, float b) { return std::fabs(a - b) / std::max(std::fabs(a), 1e-3f); };
            float diff = std::max({rel(alone.L1.x, b.L1.x), rel(alone.L1.z, b.L1.z),
                                   rel(alone.transmittance.x, b.transmittance.x), rel(alone.depth, b.depth),
                                   rel(alone.L0.y, b.L0.y)});
            for (size_t c = 0; c < stride; ++c)  // every light's AOV
                diff = std::max(diff, rel(light[c], batchLight[size_t(i) * stride + c]));
            EXPECT_TRUE(std::isfinite(b.L1.x) && std::isfinite(b.depth)) << "ray " << first + size_t(i);
            if (diff > tolerance)
                ++differing;
            else
                *worstAgreeing = std::max(*worstAgreeing, double(diff));
        }
    }
    return differing;
}

}  // namespace

TEST(EightRays, LanesAgreeWithTheScalarMarchRayByRay)
{
    if (!NIMBUS_EIGHT_RAY_MARCH)
        GTEST_SKIP() << "built without AVX2 and FMA: every ray takes the scalar march";
    for (float step : {0.5f, 1.0f, 3.5f}) {
        Scene scene = greyCloudKeyLight(step);
        scene.background = splat(0.25f);
        auto ctx = RenderContext::create(scene, true);
        const std::vector<Ray> rays = probeRays(4000, 3);
        double worst = 0.0;
        // Batches of 8 (whole packets) and of 13 (a full packet and a partial one).
        for (int batch : {8, 13}) {
            const int differing = raysThatDiffer(*ctx, rays, batch, 1e-4f, &worst);
            std::printf("step %.1f voxels, batches of %d: %d of %zu rays differ by > 1e-4 (a sample on a brick face); "
                        "worst relative difference of the others %.2g\n",
                        step, batch, differing, rays.size(), worst);
            EXPECT_LE(differing, int(rays.size() / 1000)) << "step " << step;  // at most 0.1% of rays
            // The rest differ by float rounding only: ~2^-24 relative per sample, summed over at
            // most ~150 samples, under 1e-5.
            EXPECT_LT(worst, 1e-5);
        }
    }
}

TEST(EightRays, KeyAndFillLanesAgreeWithTheScalarMarch)
{
    if (!NIMBUS_EIGHT_RAY_MARCH)
        GTEST_SKIP() << "built without AVX2 and FMA: every ray takes the scalar march";
    // Two distant lights (the default scene's key and fill): one accumulator per light in the
    // lanes, the scalar marchOneVolume<grey> with its per-light sums; per-light AOVs compared.
    Scene scene = greyCloudKeyLight(1.5f);
    scene.lights.push_back(distantLight("fill", make_float3(-1.0f, -0.3f, -0.5f), make_float3(0.11f, 0.15f, 0.22f)));
    auto ctx = RenderContext::create(scene, true);
    ASSERT_EQ(ctx->lights.size(), 2u);
    double worst = 0.0;
    const std::vector<Ray> rays = probeRays(3000, 4);
    const int differing = raysThatDiffer(*ctx, rays, 8, 1e-4f, &worst);
    std::printf("key + fill: %d of %zu rays differ by > 1e-4; worst relative difference of the others %.2g\n",
                differing, rays.size(), worst);
    EXPECT_LE(differing, int(rays.size() / 1000));
    EXPECT_LT(worst, 1e-5);  // float rounding, as above
}

TEST(EightRays, KeyAndSkyLanesAgreeWithTheScalarMarch)
{
    if (!NIMBUS_EIGHT_RAY_MARCH)
        GTEST_SKIP() << "built without AVX2 and FMA: every ray takes the scalar march";
    // A sun and a uniform sky (SkyLight.h): the lanes read the sky grid with one cursor per lane,
    // the scalar marchOneVolume<grey> with its own; the same contraction and trilinear blend.
    Scene scene = greyCloudKeyLight(1.0f);
    Light sky;
    sky.name = "sky";
    sky.type = LightType::Environment;
    sky.radiance = make_float3(0.3f, 0.4f, 0.6f);
    scene.lights.push_back(sky);
    auto ctx = RenderContext::create(scene, true);
    ASSERT_TRUE(ctx->lights[1].sky.has_value());
    double worst = 0.0;
    const std::vector<Ray> rays = probeRays(3000, 6);
    const int differing = raysThatDiffer(*ctx, rays, 8, 1e-4f, &worst);
    std::printf("key + sky: %d of %zu rays differ by > 1e-4; worst relative difference of the others %.2g\n",
                differing, rays.size(), worst);
    EXPECT_LE(differing, int(rays.size() / 1000));
    EXPECT_LT(worst, 1e-5);  // float rounding, as above
}

TEST(EightRays, OtherScenesMarchRayByRayUnchanged)
{
    // A chromatic medium, or a point light, does not take the lanes: batches must equal single
    // rays exactly.
    Scene chromatic = greyCloudKeyLight(1.0f);
    chromatic.volumes[0].medium.sigma_a = make_float3(0.1f, 0.3f, 0.9f);
    Scene pointLit = greyCloudKeyLight(1.0f);
    Light point;
    point.name = "bulb";
    point.type = LightType::Point;
    point.position = make_float3(2, 2, 2);
    point.intensity = splat(5.0f);
    pointLit.lights.push_back(point);
    for (const Scene* scene : {&chromatic, &pointLit}) {
        auto ctx = RenderContext::create(*scene, true);
        double worst = 0.0;
        EXPECT_EQ(raysThatDiffer(*ctx, probeRays(400, 9), 8, 0.0f, &worst), 0);
    }
}
