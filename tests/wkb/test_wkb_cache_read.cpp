// The radiance cache read by single's eight-ray march (InScatterGrid.h, MarchEightRays.cpp):
// L = int T sigma_s S dt summed with L1's own samples. For a field S constant along a ray the
// quadrature is exact: L1's per-step weights w_k = (1 - e^{-sigma_t rho_k dt}) / (sigma_t rho_k)
// telescope, sum_k T_k w_k rho_k sigma_t = 1 - T_out, so
//
//     L_c = sigma_s,c / sigma_t * (1 - T_out) * S_c(ray)
//
// with T_out the ray's own transmittance, whatever the box's faces do. A field linear in the two
// axes across the ray is constant along it, and trilinear interpolation reproduces it exactly
// between the outer cell centres: so each axis's index arithmetic is checked by the rays along
// the other two. With one layer and with three (a cache with per-light layers), each its own field.
// The tolerance, 1e-4 relative, is float rounding only: the identity is exact, and the sums run
// over at most ~160 samples in single precision (about 160 x 6e-8 = 1e-5 each way).
#include "../render/SceneBuilders.h"

#include "render/RenderContext.h"
#include "single/SingleScatter.h"
#include "wkb/RadianceGrid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace nimbus;
using namespace nimbus::test;

namespace {

// S_c(x) = a_c + b_c . x, per channel, with b_c's component along `axis` (the rays') left out.
const float kA[3] = {1.0f, 2.0f, 3.0f};
const float3 kB[3] = {{0.10f, -0.20f, 0.15f}, {-0.25f, 0.05f, 0.30f}, {0.20f, 0.35f, -0.10f}};

float field(int c, int axis, float3 x)
{
    float3 b = kB[c];
    (axis == 0 ? b.x : axis == 1 ? b.y : b.z) = 0.0f;
    return kA[c] + dot(b, x);
}

}  // namespace

TEST(WkbCacheRead, EightRayMarchReadsTheCacheWithL1sQuadrature)
{
    Scene scene = emptyScene(16, 16);
    const Rgb sigmaS = make_float3(1.0f, 1.5f, 1.9f), sigmaA = make_float3(1.0f, 0.5f, 0.1f);  // sigma_t 2, grey
    scene.volumes.push_back(homogeneousBox(2.0f, 2.0f, 2.0f, 0.05f, sigmaS, sigmaA));
    scene.lights.push_back(distantLight("sun", normalize(make_float3(0.3f, -1.0f, 0.2f)), splat(2.0f)));
    auto ctx = RenderContext::create(scene, true);
    if (singleRouteOf(*ctx, true) != SingleRoute::GreyDistantEight)
        GTEST_SKIP() << "built without AVX2 and FMA: the cache is read by its own march";

    // 16 cells of 0.25 m over [-2, 2]^3: the box's [-1, 1]^3 lies between the outer centres. One
    // layer, and three (per-light AOVs), layer k holding (k + 1) S + k.
    for (int layers : {1, 3}) {
        wkb::RadianceGrid grid;
        Bbox box;
        box.lo = splat(-2.0f);
        box.hi = splat(2.0f);
        grid.init(box, 0.25f, 16, layers);
        ASSERT_EQ(grid.size(0), 16);
        InScatterGrid view;
        ASSERT_TRUE(grid.view(view));
        ASSERT_EQ(view.layers, layers);
        auto layerField = [&](int layer, int c, int axis, float3 x) {
            return float(layer + 1) * field(c, axis, x) + float(layer);
        };

        // Eleven rays (a batch of eight and one of three) along each axis into the box, the last of
        // them missing it.
        for (int axis = 0; axis < 3; ++axis) {
            for (int z = 0; z < 16; ++z)
                for (int y = 0; y < 16; ++y)
                    for (int x = 0; x < 16; ++x) {
                        const float3 centre =
                            grid.box().lo + make_float3(x + 0.5f, y + 0.5f, z + 0.5f) * grid.cellSize();
                        float* cell =
                            grid.data().data() + ((size_t(z) * 16 + size_t(y)) * 16 + size_t(x)) * size_t(3 * layers);
                        for (int layer = 0; layer < layers; ++layer)
                            for (int c = 0; c < 3; ++c)
                                cell[3 * layer + c] = layerField(layer, c, axis, centre);
                    }
            std::vector<float3> o, d;
            // Rays held out inside the box (odd ones along x, all along y and z), so that marches,
            // and whole batches, end at several points within a group of samples that share a read
            // (8 here: cells of 10 L1 steps; MarchEightRays.cpp).
            std::vector<float> tFar;
            for (int i = 0; i < 11; ++i) {
                const bool cut = axis > 0 || i % 2;
                tFar.push_back(cut ? 4.1f + 0.137f * float(i) + 0.05f * float(axis) : INFINITY);
                const float u = -0.85f + 0.17f * float(i), v = 0.6f - 0.13f * float(i);
                float3 oi = make_float3(u, v, -5.0f), di = make_float3(0, 0, 1);
                if (axis == 0)
                    oi = make_float3(-5.0f, u, v), di = make_float3(1, 0, 0);
                else if (axis == 1)
                    oi = make_float3(v, -5.0f, u), di = make_float3(0, 1, 0);
                o.push_back(oi);
                d.push_back(di);
            }
            o.back() = make_float3(3.0f, 3.0f, 3.0f);  // misses the box
            const int n = int(o.size());
            std::vector<NbRng> rng;
            for (int i = 0; i < n; ++i)
                rng.push_back(nbRngStart(3, nb_uint(i), nb_uint(axis)));
            std::vector<CameraSample> out(static_cast<size_t>(n));
            std::vector<float> perLight(size_t(n) * 3 * ctx->lights.size(), 0.0f);
            std::vector<float3> gridL(size_t(n * layers), splat(-1.0f));
            std::vector<unsigned char> read(size_t(n), 0);
            marchSingleRays(*ctx, n, o.data(), d.data(), rng.data(), out.data(), perLight.data(), tFar.data(), nullptr,
                            &view, gridL.data(), read.data());
            for (int i = 0; i < n; ++i) {
                ASSERT_EQ(read[size_t(i)], 1) << "axis " << axis << " ray " << i;
                const float Tout = out[size_t(i)].transmittance.x;
                if (i == n - 1) {
                    EXPECT_EQ(Tout, 1.0f);
                    for (int layer = 0; layer < layers; ++layer)
                        EXPECT_EQ(gridL[size_t(i * layers + layer)].x, 0.0f);
                    continue;
                }
                ASSERT_LT(Tout, tFar[size_t(i)] < INFINITY ? 0.85f : 0.05f);  // e^{-4} through the box's 2 m
                for (int layer = 0; layer < layers; ++layer)
                    for (int c = 0; c < 3; ++c) {
                        const float expected =
                            component(sigmaS, c) / 2.0f * (1.0f - Tout) * layerField(layer, c, axis, o[size_t(i)]);
                        EXPECT_NEAR(component(gridL[size_t(i * layers + layer)], c), expected, 1e-4f * expected)
                            << layers << " layers, axis " << axis << " ray " << i << " layer " << layer << " channel "
                            << c;
                    }
            }
        }
    }
}
