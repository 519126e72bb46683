// HoldoutDepth's lookup rule (HoldoutDepth.h): bilinear between four surface pixels, the nearest
// pixel across a silhouette, 0 and infinity as "no holdout", coordinates scaled for a resampled
// image.
#include "geometry/HoldoutDepth.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nimbus;

TEST(HoldoutDepth, BilinearInsideNearestAcrossSilhouettes)
{
    const float inf = INFINITY;
    // 3 x 2: a ramp in the left two columns, nothing held out in the right one.
    const HoldoutDepth h(3, 2, {1, 2, 0, 3, 4, inf}, 3, 2);
    EXPECT_FLOAT_EQ(h.depthAt(0.5f, 0.5f), 1.0f);  // a pixel centre
    EXPECT_FLOAT_EQ(h.depthAt(1.0f, 1.0f), 2.5f);  // between four surface pixels
    EXPECT_FLOAT_EQ(h.depthAt(1.25f, 0.5f), 1.75f);
    // Between a surface and the empty column: the pixel holding the point.
    EXPECT_FLOAT_EQ(h.depthAt(1.9f, 0.5f), 2.0f);
    EXPECT_EQ(h.depthAt(2.1f, 0.5f), inf);
    EXPECT_EQ(h.depthAt(2.5f, 1.5f), inf);
}

TEST(HoldoutDepth, HalfResolutionImageIsReadAtScaledCoordinates)
{
    // A 2 x 1 image for a 4 x 2 camera: camera pixel (x, y) reads image pixel (x / 2, y / 2).
    const HoldoutDepth h(2, 1, {5, 7}, 4, 2);
    EXPECT_FLOAT_EQ(h.depthAt(1.0f, 1.0f), 5.0f);  // image (0.5, 0.5): pixel 0's centre
    EXPECT_FLOAT_EQ(h.depthAt(3.0f, 1.0f), 7.0f);
    EXPECT_FLOAT_EQ(h.depthAt(2.0f, 1.0f), 6.0f);
}
