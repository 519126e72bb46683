// StepCount.h: how many equal steps of at most `step` cover `length`, as an int a march can count.
//
// The marches take n = ceil(length / step) steps. At the documented extremes that ratio passes
// INT_MAX (render.shadow_step = 1e-9 voxels across an 8-voxel span is 8e9 steps), and converting
// such a float to int is undefined behaviour (issue 18, item 2: "integer arithmetic cannot
// overflow"). stepCount is at least 1 (also for NaN and 0 / 0) and at most kMaxSteps; past that
// the steps are longer than asked, on a march that takes hours either way and that cancel stops
// (docs/robustness.md).
#pragma once

#include <algorithm>
#include <cmath>

namespace nimbus {

constexpr int kMaxSteps = 1 << 30;

inline int stepCount(float length, float step)
{
    const float n = std::ceil(length / step);
    return n >= 1.0f ? int(std::min(n, float(kMaxSteps))) : 1;
}

}  // namespace nimbus
