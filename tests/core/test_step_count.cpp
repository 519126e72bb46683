// stepCount (src/core/StepCount.h): the marches' step counts stay ints at every ratio of length to
// step the scene keys allow (issue 18, item 2), including ones past INT_MAX, and NaN.
#include "core/StepCount.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace nimbus;

TEST(StepCount, CeilOfTheRatioWithinTheRange)
{
    EXPECT_EQ(stepCount(1.0f, 0.25f), 4);
    EXPECT_EQ(stepCount(1.0f, 0.3f), 4);  // the last step shorter: ceil
    EXPECT_EQ(stepCount(0.1f, 1.0f), 1);
    EXPECT_EQ(stepCount(1000.0f, 1.0f), 1000);
}

TEST(StepCount, AtLeastOneStep)
{
    EXPECT_EQ(stepCount(0.0f, 1.0f), 1);
    EXPECT_EQ(stepCount(-1.0f, 1.0f), 1);
    EXPECT_EQ(stepCount(0.0f, 0.0f), 1);  // 0 / 0
    EXPECT_EQ(stepCount(std::numeric_limits<float>::quiet_NaN(), 1.0f), 1);
}

// render.shadow_step = 1e-9 voxels across 8 voxels is 8e9 steps: past INT_MAX, where a float to int
// conversion is undefined (UBSan's float-cast-overflow); the count stops at kMaxSteps.
TEST(StepCount, RatiosPastIntMaxStopAtTheBound)
{
    EXPECT_EQ(stepCount(8.0f, 1e-9f), kMaxSteps);
    EXPECT_EQ(stepCount(1.0f, 0.0f), kMaxSteps);  // inf
    EXPECT_EQ(stepCount(3e38f, 1e-30f), kMaxSteps);
    EXPECT_EQ(stepCount(float(kMaxSteps) * 0.5f, 1.0f), kMaxSteps / 2);
}
