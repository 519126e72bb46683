// Single scattering's source at one point (src/single/ScatterSource.h) against the camera march it
// is the integrand of: along a ray o + s d, marchSingle's L1 is
//
//     L1 = int ds T(0, s) sigma_s(s) S(x(s), d)
//
// so the mean of W S(y, d) over points y drawn by ScatterPointSampler (W = T b / pdf) must equal
// it, per light: the sun (a deep shadow map on the voxels), a point light (1/r^2 and its own
// map) and a uniform sky (the sky grid, and its forward tail, read with the transmittance from
// y to the ray's end). Both are unbiased for a piecewise-constant medium but quadrature differs:
// the sampler's steps are twice the march's, with the coefficients constant across each, and the
// march's stiff bricks (StiffVoxels.h) integrate the light's optical depth by the secant rule
// where the point reads it exactly. The bound, 3% plus four standard errors, is that quadrature's
// (tests/wkb/test_wkb_traced_order2.cpp holds the traced order 2 built on this to the same 3%
// against a brute force written without nimbus's marchers).
#include "../render/SceneBuilders.h"

#include "../../kernels/shared/rng.h"
#include "render/RenderContext.h"
#include "single/ScatterPoints.h"
#include "single/ScatterSource.h"
#include "single/SingleScatter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace nimbus;
using namespace nimbus::test;

namespace {

double mean3(Rgb v) { return (double(v.x) + v.y + v.z) / 3.0; }

Scene litScene(Volume volume)
{
    Scene s = emptyScene(8, 8);
    s.render.method = Method::Single;
    s.volumes.push_back(std::move(volume));
    s.lights.push_back(distantLight("sun", make_float3(-0.64f, -0.77f, -0.2f), splat(3.0f)));
    s.lights.push_back(pointLight("lamp", make_float3(1.6f, 0.9f, 1.2f), splat(2.0f)));
    s.lights.push_back(uniformSky("sky", make_float3(0.1f, 0.15f, 0.3f)));
    return s;
}

// Per light (then the sum): the march's L1 along each ray, and the point estimate's mean and
// standard error.
void checkRays(const Scene& scene, const std::vector<std::pair<float3, float3>>& rays, bool checkSky = true)
{
    auto ctx = RenderContext::create(scene, true);
    const size_t nLights = ctx->lights.size();
    int ray = 0;
    for (const auto& [o, target] : rays) {
        const float3 d = normalize(target - o);
        // The march, averaged over its jitter.
        const int marches = 64;
        std::vector<double> march(nLights + 1, 0.0);
        for (int k = 0; k < marches; ++k) {
            NbRng rng = nbRngStart(3u, nb_uint(ray * marches + k), 0u);
            CameraSample cs;
            std::vector<float> perLight(3 * nLights, 0.0f);
            marchSingle(*ctx, o, d, rng, cs, perLight.data());
            for (size_t i = 0; i < nLights; ++i)
                march[i] += (double(perLight[3 * i]) + perLight[3 * i + 1] + perLight[3 * i + 2]) / 3.0 / marches;
            march[nLights] += mean3(cs.L1) / marches;
        }
        // The point estimate.
        const int n = 40000;
        std::vector<double> sum(nLights + 1, 0.0), sum2(nLights + 1, 0.0);
        ScatterPointSampler points;
        for (int k = 0; k < n; ++k) {
            NbRng rng = nbRngStart(5u, nb_uint(ray * n + k), 0u);
            std::vector<float> perLight(3 * nLights, 0.0f);
            Rgb S = splat(0.0f);
            ScatterPoint y{};
            if (points.march(*ctx, o, d, INFINITY, rng)) {
                y = points.draw(o, d, 0, 1, rng);
                // The tail's share, T(y, end); none where the march stops at the tolerance.
                const Rgb T = points.transmittance();
                const Rgb behind = nbMaxComponent(T) >= scene.render.tolerance
                                       ? make_float3(float(T.x / y.T[0]), float(T.y / y.T[1]), float(T.z / y.T[2]))
                                       : splat(0.0f);
                S = singleScatterSource(*ctx, y.x, d, behind, rng, perLight.data());
            }
            for (size_t i = 0; i <= nLights; ++i) {
                const Rgb s = i < nLights ? make_float3(perLight[3 * i], perLight[3 * i + 1], perLight[3 * i + 2]) : S;
                const double v = (y.W[0] * s.x + y.W[1] * s.y + y.W[2] * s.z) / 3.0;
                sum[i] += v;
                sum2[i] += v * v;
            }
        }
        for (size_t i = 0; i <= nLights; ++i) {
            if (!checkSky && (i == nLights || scene.lights[i].type == LightType::Environment))
                continue;
            const double mean = sum[i] / n;
            const double err = std::sqrt(std::max(0.0, sum2[i] / n - mean * mean) / n);
            const char* name = i < nLights ? scene.lights[i].name.c_str() : "all";
            EXPECT_NEAR(mean, march[i], 0.03 * march[i] + 4.0 * err)
                << "ray " << ray << ", light " << name << ": points " << mean << " +- " << err << ", march "
                << march[i];
            EXPECT_GT(march[i], 0.0) << "ray " << ray << ", light " << name;
        }
        ++ray;
    }
}

}  // namespace

// A heterogeneous cloud, forward-scattering (g 0.8: the sky grid leaves a tail), thin to
// moderate voxels: the lattice's light read.
TEST(ScatterSource, IntegratesToTheMarchsL1InACloud)
{
    const Scene scene = litScene(proceduralCloud(0.05, splat(3.0f), splat(0.1f), 0.8f));
    checkRays(scene, {{make_float3(0.2f, 0.3f, 4.0f), make_float3(0.0f, 0.1f, 0.0f)},
                      {make_float3(-3.0f, 0.5f, 2.5f), make_float3(0.2f, 0.0f, -0.1f)},
                      {make_float3(0.5f, 3.5f, 1.0f), make_float3(-0.1f, 0.2f, 0.0f)}});
}

// A box of voxel optical depth 12: stiff bricks, where the light's optical depth is marched back
// from the point (the march: from each sub-step's ends). The sun and the lamp only: across a
// stiff camera step the march reads the sky grid once, at the step's middle (SingleScatter.cpp),
// which at this face lies a quarter voxel deeper than the light it stands for (the points, read
// where they fall, gave 7.6% more of the sky).
TEST(ScatterSource, IntegratesToTheMarchsL1InStiffVoxels)
{
    const Scene scene = litScene(homogeneousBox(1.0f, 1.0f, 1.0f, 1.0f / 16, splat(180.0f), splat(12.0f), 0.3f));
    checkRays(scene, {{make_float3(0.1f, 0.2f, 3.0f), make_float3(0.0f, 0.1f, 0.0f)},
                      {make_float3(-2.0f, 2.0f, 1.0f), make_float3(0.0f, 0.3f, 0.1f)}},
              false);
}
