// One reference for the specialised camera marchers (SingleScatter.cpp, MarchEightRays.cpp): on
// a scene that routes to each of them, every ray is marched through its specialised loop and
// through the general scalar loop (marchSingleGeneralReference, the same samples), and the two
// must agree ray by ray in L0, L1, every light's L1, transmittance, depth and opacity.
//
// The bound is float rounding, not a tolerance fitted to pass. Both marches evaluate the same
// terms at the same lattice t_k; what differs is how each computes a sample's index-space
// position (the general loop o + t d in world space, then the volume's matrix; the specialised
// ones o_i + t d_i in index space, then the brick's corner): a few roundings of coordinates of at
// most ~100 voxels, ~2^-24 * 100 * 4 = 3e-5 voxels. Through the trilinear lookups (density, each
// light's baked optical depth) that moves a sample's value by at most its voxel-to-voxel change
// times 3e-5, and the sums over samples, the product of step transmittances and the
// reassociated RGB factors add ~2^-24 per operation over at most a few hundred samples. A ray
// agrees when every quantity is within kRel = 1e-4 of the reference, relative to
// max(|reference|, kFloor) (kFloor = 1e-3 of the quantity's largest value over the rays, below
// which a difference is invisible and rounding of near-cancelling steps dominates).
// Two rare events move a ray by more: a sample within rounding of a brick face whose neighbour
// is unallocated (one march reads the brick, the other the empty neighbour, as
// test_eight_rays.cpp explains), and a transmittance within rounding of the cut-off
// (render.tolerance), where one march stops a sample earlier. At most 0.1% of rays may differ
// for those; a loop that skips a sample, reads a wrong light or drops a term moves most rays by
// far more than kRel and fails.
#include "../render/SceneBuilders.h"
#include "ProbeRays.h"

#include "render/RenderContext.h"
#include "single/MarchEightRays.h"
#include "single/SingleScatter.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace nimbus;
using namespace nimbus::test;

namespace {

constexpr double kRel = 1e-4;
constexpr double kFloor = 1e-3;
constexpr double kMostDiffering = 0.001;

// `thin`: a quarter of the extinction, so that no voxel is stiff (sigma_t h rho < kFlatCell,
// StiffVoxels.h: 1.575 / m at a 0.05 m voxel is 0.079): stiff bricks send every ray of a frame
// to the one-ray march, and the eight-ray loop would not be tested.
Scene cloudScene(bool grey, float step, bool thin = false)
{
    Scene s = emptyScene(64, 48);
    s.volumes.push_back(proceduralCloud(0.05, splat(6.0f), grey ? splat(0.3f) : make_float3(0.1f, 0.5f, 1.5f), 0.5f));
    if (thin) {
        s.volumes[0].medium.sigma_s = s.volumes[0].medium.sigma_s * 0.25f;
        s.volumes[0].medium.sigma_a = s.volumes[0].medium.sigma_a * 0.25f;
    }
    if (!grey)
        s.volumes[0].medium.sigma_s = make_float3(7.0f, 6.0f, 4.5f);
    s.lights.push_back(distantLight("key", make_float3(0.4f, -1.0f, -0.6f), make_float3(3.0f, 2.8f, 2.5f)));
    s.render.step = step;
    s.render.seed = 5;
    s.background = make_float3(0.2f, 0.25f, 0.3f);
    return s;
}

void addFill(Scene& s)
{
    s.lights.push_back(distantLight("fill", make_float3(-1.0f, -0.3f, -0.5f), make_float3(0.11f, 0.15f, 0.22f)));
}

void addBulb(Scene& s)
{
    Light point;
    point.name = "bulb";
    point.type = LightType::Point;
    point.position = make_float3(1.5f, 1.2f, 1.8f);
    point.intensity = make_float3(5.0f, 4.0f, 3.0f);
    s.lights.push_back(point);
}

// The quantities compared, per ray: L0, L1, transmittance (RGB each), depth, opacity, then 3 per light.
std::vector<float> quantities(const CameraSample& c, const float* perLight, size_t stride)
{
    std::vector<float> q = {
        c.L0.x,  c.L0.y,   c.L0.z, c.L1.x, c.L1.y, c.L1.z, c.transmittance.x, c.transmittance.y, c.transmittance.z,
        c.depth, c.opacity};
    q.insert(q.end(), perLight, perLight + stride);
    return q;
}
const char* kNames[] = {"L0.r", "L0.g", "L0.b", "L1.r", "L1.g", "L1.b", "T.r", "T.g", "T.b", "depth", "opacity"};

std::string nameOf(size_t i)
{
    return i < 11 ? kNames[i] : "light" + std::to_string((i - 11) / 3) + "." + "rgb"[(i - 11) % 3];
}

// Marches every ray through the route under test (batches of 8 when `batch`) and through the
// reference; returns how many rays differ beyond the rounding bound, printing the worst
// relative difference of the agreeing ones (per quantity) and replay data for the worst ray.
int raysThatDiffer(const RenderContext& ctx, const std::vector<Ray>& rays, bool batch, const char* label)
{
    const size_t stride = 3 * ctx.lights.size();
    const size_t nq = 11 + stride;
    std::vector<std::vector<float>> got(rays.size()), ref(rays.size());
    const int width = batch ? 8 : 1;
    for (size_t first = 0; first < rays.size(); first += size_t(width)) {
        const int n = int(std::min(rays.size() - first, size_t(width)));
        std::vector<CameraSample> out(1);
        std::vector<float> light(stride, 0.0f);
        if (batch) {
            marchBatch(ctx, rays, first, n, 11, out, light);
        } else {
            NbRng rng = nbRngStart(11, nb_uint(first), 0);
            marchSingle(ctx, rays[first].o, rays[first].d, rng, out[0], light.data());
        }
        for (int i = 0; i < n; ++i) {
            got[first + size_t(i)] = quantities(out[size_t(i)], light.data() + stride * size_t(i), stride);
            NbRng r = nbRngStart(11, nb_uint(first) + nb_uint(i), 0);
            CameraSample c;
            std::vector<float> l(stride, 0.0f);
            marchSingleGeneralReference(ctx, rays[first + size_t(i)].o, rays[first + size_t(i)].d, r, c, l.data());
            ref[first + size_t(i)] = quantities(c, l.data(), stride);
        }
    }
    std::vector<double> largest(nq, 0.0), worst(nq, 0.0);
    for (const auto& q : ref)
        for (size_t j = 0; j < nq; ++j)
            largest[j] = std::max(largest[j], double(std::fabs(q[j])));
    int differing = 0;
    size_t worstRay = 0;
    double worstAll = 0.0;
    for (size_t r = 0; r < rays.size(); ++r) {
        double rayWorst = 0.0;
        std::vector<double> rel(nq);
        for (size_t j = 0; j < nq; ++j) {
            EXPECT_TRUE(std::isfinite(got[r][j])) << label << " ray " << r << " " << nameOf(j);
            const double floor = std::max(kFloor * largest[j], 1e-30);
            rel[j] = std::fabs(double(got[r][j]) - double(ref[r][j])) / std::max(double(std::fabs(ref[r][j])), floor);
            rayWorst = std::max(rayWorst, rel[j]);
        }
        if (rayWorst > kRel) {
            ++differing;
            continue;
        }
        for (size_t j = 0; j < nq; ++j)
            worst[j] = std::max(worst[j], rel[j]);
        if (rayWorst > worstAll)
            worstAll = rayWorst, worstRay = r;
    }
    std::printf("%s: %d of %zu rays differ by > %.0e; worst relative difference of the others %.2g (ray %zu, o = "
                "(%.9g, %.9g, %.9g), d = (%.9g, %.9g, %.9g)); per quantity:",
                label, differing, rays.size(), kRel, worstAll, worstRay, rays[worstRay].o.x, rays[worstRay].o.y,
                rays[worstRay].o.z, rays[worstRay].d.x, rays[worstRay].d.y, rays[worstRay].d.z);
    for (size_t j = 0; j < nq; ++j)
        std::printf(" %s %.1g", nameOf(j).c_str(), worst[j]);
    std::printf("\n");
    return differing;
}

struct Case {
    const char* label;
    Scene scene;
    SingleRoute route;
    bool batch;
};

void checkRoute(const Case& c, int rayCount, unsigned seed)
{
    auto ctx = RenderContext::create(c.scene, true);
    ASSERT_EQ(int(singleRouteOf(*ctx, c.batch)), int(c.route)) << c.label << ": the scene does not route there";
    const std::vector<Ray> rays = probeRays(rayCount, seed);
    const int differing = raysThatDiffer(*ctx, rays, c.batch, c.label);
    EXPECT_LE(differing, int(kMostDiffering * double(rays.size()))) << c.label;
}

}  // namespace

TEST(MarcherReference, GreyKeyLightEqualsTheGeneralMarch)
{
    for (float step : {0.5f, 1.5f})
        checkRoute({"marchGreyKeyLight", cloudScene(true, step), SingleRoute::GreyKeyLight, false}, 3000, 21);
}

TEST(MarcherReference, GreyKeySkyEqualsTheGeneralMarch)
{
    // A sun and a uniform sky (SkyLight.h), one ray at a time (wkb's camera and secondary rays):
    // marchGreyKeyLight<Sky> reads the sky grid at every sample as the general loop does. Thin:
    // the general loop takes no stiff sub-steps where a light (the sky) is not baked.
    for (float step : {0.5f, 1.5f}) {
        Scene s = cloudScene(true, step, true);
        Light sky;
        sky.name = "sky";
        sky.type = LightType::Environment;
        sky.radiance = make_float3(0.3f, 0.4f, 0.6f);
        s.lights.push_back(sky);
        checkRoute({"marchGreyKeyLight<sky>", s, SingleRoute::GreyKeySky, false}, 3000, 27);
    }
}

TEST(MarcherReference, OneVolumeLoopsEqualTheGeneralMarch)
{
    // marchOneVolume<grey>: a distant key, a distant fill and a point light (its weight per sample).
    Scene grey = cloudScene(true, 1.0f);
    addFill(grey);
    addBulb(grey);
    // marchOneVolume<chromatic, one distant light>, and with a point light and a fill.
    Scene chromatic = cloudScene(false, 1.0f);
    Scene chromaticLights = chromatic;
    addBulb(chromaticLights);
    addFill(chromaticLights);
    const Case cases[] = {{"marchOneVolume<true, false>", grey, SingleRoute::Grey, false},
                          {"marchOneVolume<false, true>", chromatic, SingleRoute::OneDistant, false},
                          {"marchOneVolume<false, false>", chromaticLights, SingleRoute::Chromatic, false}};
    for (unsigned i = 0; i < 3; ++i)
        checkRoute(cases[i], 3000, 22 + i);
}

TEST(MarcherReference, GreyDistantEightEqualsTheGeneralMarch)
{
    for (float step : {0.5f, 1.5f})
        ASSERT_FALSE(RenderContext::create(cloudScene(true, step, true), true)->stiff[0].any)
            << "the thin cloud has stiff bricks at step " << step << ": it would not test the eight-ray loop";
#if !NIMBUS_EIGHT_RAY_MARCH
    GTEST_SKIP() << "built without the eight-ray march (NIMBUS_EIGHT_RAY_MARCH: AVX2 and FMA): batches take the "
                    "scalar loops";
#endif
    for (float step : {0.5f, 1.5f}) {
        Scene key = cloudScene(true, step, true);
        checkRoute({"marchGreyDistantEight, key", key, SingleRoute::GreyDistantEight, true}, 3000, 25);
        addFill(key);
        checkRoute({"marchGreyDistantEight, key + fill", key, SingleRoute::GreyDistantEight, true}, 3000, 26);
    }
}

TEST(MarcherReference, GeneralSceneRoutesToTheGeneralMarch)
{
    // Two volumes: only the general loop handles them; the reference is that loop itself.
    Scene s = cloudScene(true, 1.0f);
    s.volumes.push_back(homogeneousBox(0.5f, 0.5f, 0.5f, 0.05f, splat(2.0f), splat(0.1f)));
    auto ctx = RenderContext::create(s, true);
    EXPECT_EQ(int(singleRouteOf(*ctx, false)), int(SingleRoute::General));
    EXPECT_EQ(int(singleRouteOf(*ctx, true)), int(SingleRoute::General));
}
