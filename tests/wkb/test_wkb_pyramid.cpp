// The light pyramid (src/wkb/LightPyramid): its blur against explicit Gaussian convolution, the
// exactness of its moments, the normalised (density-weighted) read, and sparse memory.
#include "wkb/LightPyramid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

using namespace nimbus;
using namespace nimbus::wkb;

namespace {

constexpr int S = BrickGrid::kStored;

// Level 0 over bricks [lo, hi]^3 (brick coordinates), channels filled by f(i, j, k, c).
LightPyramid makePyramid(int lo, int hi, int channels, const std::function<float(int, int, int, int)>& f)
{
    std::vector<Int3> bricks;
    for (int z = lo; z <= hi; ++z)
        for (int y = lo; y <= hi; ++y)
            for (int x = lo; x <= hi; ++x)
                bricks.push_back({x, y, z});
    LightPyramid p;
    p.allocateLevel0(bricks, channels);
    for (size_t b = 0; b < p.level0BrickCount(); ++b) {
        Int3 c = p.level0Brick(b);
        float* v = p.level0Values(b);
        for (int z = 0; z < S; ++z)
            for (int y = 0; y < S; ++y)
                for (int x = 0; x < S; ++x)
                    for (int ch = 0; ch < channels; ++ch)
                        v[((z * S + y) * S + x) * channels + ch] = f(8 * c.x + x, 8 * c.y + y, 8 * c.z + z, ch);
    }
    return p;
}

float at(const LightPyramid& p, int k, float3 p0, int c)
{
    float v = 0.0f;
    p.fetchLevel(k, p0, c, 1, 1.0f, &v);
    return v;
}

}  // namespace

// An impulse: level k holds the filter cascade's kernel sampled on its lattice. Its mass is 1 and
// its variance per axis is exactly sigma_k^2 = (4^k - 1)/3: each [1 4 6 4 1]/16 pass adds 1 in the
// finer level's units, and decimation keeps both moments (the even and the odd taps have equal
// sums and equal second moments). Pointwise the sampled kernel is not a Gaussian (level 1 holds
// (6/16)^3 at the centre against the Gaussian's 0.0635): a mip level is under-resolved for its own
// blur, which is why reads interpolate; the shape is checked on band-limited fields below.
TEST(WkbPyramid, ImpulseResponseHasTheMomentsOfSigmaK)
{
    LightPyramid p =
        makePyramid(-8, 7, 1, [](int i, int j, int k, int) { return i == 0 && j == 0 && k == 0 ? 1.0f : 0.0f; });
    p.buildLevels(1e9f, 5);
    ASSERT_EQ(p.levels(), 5);
    for (int k = 1; k < 5; ++k) {
        const int step = 1 << k;
        const double vol = double(step) * step * step;  // level-0 voxels per level-k voxel
        const double sigma2 = (std::pow(4.0, k) - 1.0) / 3.0;
        EXPECT_NEAR(LightPyramid::sigmaOfLevel(float(k)) * LightPyramid::sigmaOfLevel(float(k)), sigma2, 1e-3);
        double mass = 0, m2 = 0;
        const int r = 6;  // level-k voxels, > 3.5 sigma
        for (int z = -r; z <= r; ++z)
            for (int y = -r; y <= r; ++y)
                for (int x = -r; x <= r; ++x) {
                    float3 q = make_float3(float(x * step), float(y * step), float(z * step));
                    double v = at(p, k, q, 0);
                    mass += v * vol;
                    m2 += v * vol * q.x * q.x;
                }
        EXPECT_NEAR(mass, 1.0, 1e-5) << "level " << k;
        EXPECT_NEAR(m2 / sigma2, 1.0, 1e-4) << "level " << k;
    }
}

// A smooth field (1 + 0.5 times a product of cosines of wavelengths 40, 24 and 12 voxels) against
// its explicit convolution with the Gaussian of sigma_k, summed directly over level 0. For a
// cosine of wavenumber w the cascade multiplies by prod_{i<k} cos^4(w 2^i / 2) (the binomial's
// transfer at each level's spacing) and the Gaussian by exp(-w^2 sigma_k^2 / 2); the tolerance is
// that difference for this field (plus float rounding), computed here, not chosen. The pyramid
// must also equal the cascade's prediction to float precision.
TEST(WkbPyramid, BlurMatchesExplicitGaussianConvolution)
{
    const double kx = 2 * M_PI / 40.0, ky = 2 * M_PI / 24.0, kz = 2 * M_PI / 12.0;
    auto field = [&](double i, double j, double k) {
        return 1.0 + 0.5 * std::cos(kx * i) * std::cos(ky * j + 0.3) * std::cos(kz * k);
    };
    LightPyramid p = makePyramid(-10, 9, 1, [&](int i, int j, int k, int) { return float(field(i, j, k)); });
    p.buildLevels(1e9f, 3);
    for (int k = 1; k < 3; ++k) {
        const double sigma2 = (std::pow(4.0, k) - 1.0) / 3.0;
        double cascade = 1.0, gauss = 1.0;
        for (double w : {kx, ky, kz}) {
            for (int i = 0; i < k; ++i)
                cascade *= std::pow(std::cos(0.5 * w * std::ldexp(1.0, i)), 4);
            gauss *= std::exp(-0.5 * w * w * sigma2);
        }
        const double tolerance = 0.5 * std::fabs(cascade - gauss) + 1e-5;
        const int R = int(std::ceil(6.0 * std::sqrt(sigma2)));
        for (float3 q : {make_float3(0, 0, 0), make_float3(8, -4, 12), make_float3(-16, 20, 4)}) {
            double num = 0, den = 0;
            for (int z = -R; z <= R; ++z)
                for (int y = -R; y <= R; ++y)
                    for (int x = -R; x <= R; ++x) {
                        double w = std::exp(-0.5 * (x * x + y * y + z * z) / sigma2);
                        num += w * field(q.x + x, q.y + y, q.z + z);
                        den += w;
                    }
            const double pyramid = at(p, k, q, 0);
            const double predicted = 1.0 + 0.5 * cascade * (field(q.x, q.y, q.z) - 1.0) / 0.5;
            EXPECT_NEAR(pyramid, predicted, 1e-5) << "level " << k;
            EXPECT_NEAR(pyramid, num / den, tolerance)
                << "level " << k << " (cascade vs Gaussian transfer " << cascade << " vs " << gauss << ")";
        }
    }
}

// Fractional levels blend the two nearest linearly, and levelForSigma inverts sigmaOfLevel.
TEST(WkbPyramid, LookupInterpolatesAcrossLevels)
{
    for (float k : {0.0f, 0.5f, 1.0f, 2.25f, 4.0f})
        EXPECT_NEAR(LightPyramid::levelForSigma(LightPyramid::sigmaOfLevel(k)), k, 1e-4f);
    LightPyramid p = makePyramid(-4, 3, 1, [](int i, int, int, int) { return float(i % 7 == 0); });
    p.buildLevels(1e9f, 4);
    float3 q = make_float3(3.3f, -2.1f, 5.7f);
    float v = 0.0f;
    p.fetch(q, LightPyramid::sigmaOfLevel(1.25f), 0, 1, 1.0f, &v);
    EXPECT_NEAR(v, 0.75f * at(p, 1, q, 0) + 0.25f * at(p, 2, q, 0), 1e-6f);
}

// Channel / channel 0 is a density-weighted average: a source proportional to the density reads
// back the constant everywhere, at every blur, also where the blur reaches past the bricks.
TEST(WkbPyramid, NormalisedReadIgnoresTheZeroOutside)
{
    auto rho = [](int i, int j, int k) {
        return i * i + j * j + k * k < 100 ? 1.0f + 0.1f * float((i + 2 * j) % 5) : 0.0f;
    };
    LightPyramid p =
        makePyramid(-2, 1, 2, [&](int i, int j, int k, int c) { return (c ? 3.5f : 1.0f) * rho(i, j, k); });
    p.buildLevels(1e9f, 6);
    for (float sigma : {0.0f, 1.0f, 3.0f, 10.0f, 40.0f})
        for (float3 q : {make_float3(0, 0, 0), make_float3(9, 1, 0), make_float3(-7, 6, 2)}) {
            float v[2] = {0, 0};
            p.fetch(q, sigma, 0, 2, 1.0f, v);
            ASSERT_GT(v[0], 0.0f);
            EXPECT_NEAR(v[1] / v[0], 3.5f, 1e-4f) << sigma;
        }
}

// Two blobs in opposite corners of a 1024^3-voxel box: memory follows the 2 x 8 bricks, not the box.
TEST(WkbPyramid, MemoryFollowsTheActiveRegion)
{
    std::vector<Int3> bricks;
    for (int z = 0; z < 2; ++z)
        for (int y = 0; y < 2; ++y)
            for (int x = 0; x < 2; ++x) {
                bricks.push_back({x, y, z});
                bricks.push_back({126 + x, 126 + y, 126 + z});
            }
    LightPyramid p;
    p.allocateLevel0(bricks, 4);
    p.buildLevels(1e9f, LightPyramid::kMaxLevels);
    const size_t brickBytes = BrickGrid::kBrickValues * 4 * sizeof(float);
    // Level 0: 16 bricks; each coarser level the parents: 1 per blob from level 1 on (one in
    // all once the blobs' parents meet).
    EXPECT_EQ(p.level(0).brickCount(), 16u);
    for (int k = 1; k < p.levels(); ++k)
        EXPECT_LE(p.level(k).brickCount(), 2u) << k;
    // The values follow the bricks; what follows the box is BrickGrid's slot table, 8 bytes per
    // 8^3 voxels of the bounding box (the density grid pays the same), 1/1024 of a dense grid here.
    size_t values = 0, tables = 0;
    for (int k = 0; k < p.levels(); ++k) {
        values += p.level(k).brickCount() * brickBytes;
        Int3 d = p.level(k).dims();
        tables += size_t(d.x) * d.y * d.z * (sizeof(int32_t) + sizeof(float));
    }
    EXPECT_EQ(p.memoryBytes(), values + tables);
    EXPECT_LE(values, (16 + 2 * size_t(p.levels() - 1)) * brickBytes);
    const double dense = 1024.0 * 1024.0 * 1024.0 * 4 * sizeof(float);
    EXPECT_LT(double(p.memoryBytes()), 0.002 * dense);
    EXPECT_EQ(LightPyramid::levelBytes(bricks, 4), p.level(0).memoryBytes());
}
