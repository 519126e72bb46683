#include "volume/BrickGrid.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nimbus;

namespace {
// A grid holding f(i,j,k) on voxels [0, n)^3, filled brick by brick with the apron.
template <class F>
BrickGrid makeGrid(int n, F f)
{
    BrickGrid g;
    int nb = (n + BrickGrid::kBrick - 1) / BrickGrid::kBrick;
    g.reset({-1, -1, -1}, {nb + 1, nb + 1, nb + 1}, 1);
    for (int bz = 0; bz < nb + 1; ++bz)
        for (int by = 0; by < nb + 1; ++by)
            for (int bx = 0; bx < nb + 1; ++bx) {
                float* v = g.allocateBrick(bx, by, bz);
                for (int z = 0; z < BrickGrid::kStored; ++z)
                    for (int y = 0; y < BrickGrid::kStored; ++y)
                        for (int x = 0; x < BrickGrid::kStored; ++x) {
                            int i = (bx - 1) * 8 + x, j = (by - 1) * 8 + y, k = (bz - 1) * 8 + z;
                            bool inside = i >= 0 && j >= 0 && k >= 0 && i < n && j < n && k < n;
                            v[(z * BrickGrid::kStored + y) * BrickGrid::kStored + x] = inside ? f(i, j, k) : 0.0f;
                        }
            }
    g.pruneZeroBricks();
    return g;
}
}  // namespace

TEST(BrickGrid, TrilinearReproducesLinearFunction)
{
    auto f = [](int i, int j, int k) { return 1.0f + 0.5f * i - 0.25f * j + 0.125f * k; };
    BrickGrid g = makeGrid(20, f);
    for (float3 p : {make_float3(3.3f, 7.9f, 8.5f), make_float3(15.99f, 0.01f, 7.5f), make_float3(8.0f, 8.0f, 8.0f)}) {
        float expected = 1.0f + 0.5f * p.x - 0.25f * p.y + 0.125f * p.z;
        EXPECT_NEAR(g.sample(p), expected, 1e-4f);
    }
    EXPECT_EQ(g.sample(make_float3(-5, 3, 3)), 0.0f);
    EXPECT_EQ(g.sample(make_float3(NAN, 3, 3)), 0.0f);
}

TEST(BrickGrid, MajorantBoundsEverySample)
{
    BrickGrid g = makeGrid(24, [](int i, int j, int k) { return float((i * 7 + j * 13 + k * 29) % 11); });
    for (int s = 0; s < 5000; ++s) {
        float3 p = make_float3(std::fmod(s * 0.6180339f, 1.0f) * 26 - 1, std::fmod(s * 0.7548776f, 1.0f) * 26 - 1,
                               std::fmod(s * 0.5698402f, 1.0f) * 26 - 1);
        EXPECT_LE(g.sample(p), g.majorantAt(p) + 1e-5f);
    }
    EXPECT_FLOAT_EQ(g.maxValue(), 10.0f);
}
