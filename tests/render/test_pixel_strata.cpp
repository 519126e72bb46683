// The pixel's sample strata (src/render/PixelStrata.h): the stratum map is a bijection for every
// count and rotation tried; a square spp puts exactly one sample in each cell of its grid; any
// spp puts no two samples in one stratum; and each sample is uniform over the pixel (its
// coordinates' means and the share falling in each quarter of the pixel, over many keys, within
// four standard errors), so the estimates keep their means.
#include "render/PixelStrata.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

using namespace nimbus;

TEST(PixelStrata, StratumMapIsABijection)
{
    for (uint32_t count : {1u, 2u, 3u, 4u, 5u, 6u, 7u, 16u, 17u, 64u, 100u, 1000u, 4097u})
        for (uint32_t r : {0u, 1u, count / 2, count - 1}) {
            std::vector<int> hits(count, 0);
            for (uint32_t i = 0; i < count; ++i) {
                const uint32_t p = stratumOf(i, count, r);
                ASSERT_LT(p, count);
                ++hits[p];
            }
            for (uint32_t i = 0; i < count; ++i)
                ASSERT_EQ(hits[i], 1) << "count " << count << " rotation " << r << " value " << i;
        }
}

TEST(PixelStrata, SquareCountIsAJitteredGridAndNoStratumIsShared)
{
    for (int spp : {4, 9, 16, 64, 2, 3, 5, 7, 12})
        for (uint32_t key : {3u, 77u, 0x9e3779b9u}) {
            const int m = int(std::ceil(std::sqrt(double(spp)))), n = (spp + m - 1) / m;
            std::set<int> cells;
            for (int s = 0; s < spp; ++s) {
                float x, y;
                stratifiedPixelPoint(s, spp, key, 0.5f, 0.5f, x, y);
                ASSERT_GE(x, 0.0f);
                ASSERT_LT(x, 1.0f);
                ASSERT_GE(y, 0.0f);
                ASSERT_LT(y, 1.0f);
                cells.insert(int(y * float(n)) * m + int(x * float(m)));
            }
            EXPECT_EQ(int(cells.size()), spp) << "spp " << spp << ": two samples share a stratum";
        }
}

TEST(PixelStrata, EachSampleIsUniformOverThePixel)
{
    // Over many pixels (keys), sample s's point with uniform (u0, u1) from a fixed sequence: mean
    // 1/2 per axis (variance 1/12) and a quarter in each quadrant.
    const int keys = 40000;
    for (int spp : {3, 4, 5}) {
        for (int s = 0; s < spp; ++s) {
            double sx = 0, sy = 0;
            int quadrant[4] = {0, 0, 0, 0};
            for (int k = 0; k < keys; ++k) {
                const float u0 = float((k * 7919) % 1000 + 0.5) / 1000.0f, u1 = float((k * 104729) % 997 + 0.5) / 997.0f;
                float x, y;
                stratifiedPixelPoint(s, spp, uint32_t(k) * 2654435761u + 17u * uint32_t(k >> 12), u0, u1, x, y);
                sx += x;
                sy += y;
                ++quadrant[(x >= 0.5f ? 1 : 0) + (y >= 0.5f ? 2 : 0)];
            }
            const double se = std::sqrt(1.0 / 12.0 / keys);
            EXPECT_LT(std::fabs(sx / keys - 0.5), 4 * se) << "spp " << spp << " sample " << s;
            EXPECT_LT(std::fabs(sy / keys - 0.5), 4 * se) << "spp " << spp << " sample " << s;
            const double qse = std::sqrt(0.25 * 0.75 / keys);
            for (int q = 0; q < 4; ++q)
                EXPECT_LT(std::fabs(double(quadrant[q]) / keys - 0.25), 4 * qse) << "spp " << spp << " sample " << s;
        }
    }
}

TEST(PixelStrata, ShutterTimesTakeEachStratumOnceAndAreUniform)
{
    for (int spp : {2, 3, 4, 7, 16, 64, 256})
        for (uint32_t key : {1u, 99u, 0xabcdef01u}) {
            std::set<int> strata;
            for (int s = 0; s < spp; ++s) {
                const float t = stratifiedTime(s, spp, key, 0.5f);
                ASSERT_GE(t, 0.0f);
                ASSERT_LT(t, 1.0f);
                strata.insert(int(t * float(spp)));
            }
            EXPECT_EQ(int(strata.size()), spp) << "spp " << spp << ": two samples share a time stratum";
        }
    // Each sample's time is uniform over the shutter, over many pixels (keys): mean 1/2 and a
    // quarter in each quarter of the shutter.
    const int keys = 40000;
    for (int spp : {3, 8}) {
        for (int s = 0; s < spp; ++s) {
            double sum = 0;
            int quarter[4] = {0, 0, 0, 0};
            for (int k = 0; k < keys; ++k) {
                const float t = stratifiedTime(s, spp, uint32_t(k) * 2654435761u + 7u, float((k * 7919) % 1000 + 0.5) / 1000.0f);
                sum += t;
                ++quarter[std::min(3, int(t * 4.0f))];
            }
            EXPECT_LT(std::fabs(sum / keys - 0.5), 4 * std::sqrt(1.0 / 12.0 / keys)) << "spp " << spp << " sample " << s;
            for (int q = 0; q < 4; ++q)
                EXPECT_LT(std::fabs(double(quarter[q]) / keys - 0.25), 4 * std::sqrt(0.25 * 0.75 / keys))
                    << "spp " << spp << " sample " << s;
        }
    }
}
