// The launch-size chooser (src/pathtracer/LaunchSize.h), a pure function of the device's
// properties: every compute unit gets work-groups, the local size respects every limit and is
// the preferred multiple times a power of two where the image allows, and the global size is
// the smallest multiple of it that covers the items.
#include "pathtracer/LaunchSize.h"

#include <gtest/gtest.h>

#include <algorithm>

#include <string>

using namespace nimbus;

namespace {

std::string describe(size_t items, const LaunchLimits& d)
{
    return "items " + std::to_string(items) + ", units " + std::to_string(d.computeUnits) + ", kernel " +
           std::to_string(d.kernelWorkGroupSize) + ", multiple " + std::to_string(d.preferredMultiple) + ", device " +
           std::to_string(d.deviceMaxWorkGroupSize) + ", item " + std::to_string(d.deviceMaxWorkItemSize);
}

// What every launch must satisfy.
void expectValid(size_t items, const LaunchLimits& d)
{
    const LaunchSize s = chooseLaunchSize(items, d);
    const std::string what = describe(items, d);
    ASSERT_GE(s.local, 1u) << what;
    EXPECT_EQ(s.global % s.local, 0u) << what;
    EXPECT_GE(s.global, items) << what;
    EXPECT_LT(s.global - items, s.local) << what << ": a whole group of idle items";
    EXPECT_LE(s.local, kMaxChosenWorkGroupSize) << what;
    for (size_t limit : {d.kernelWorkGroupSize, d.deviceMaxWorkGroupSize, d.deviceMaxWorkItemSize})
        if (limit > 0) {
            EXPECT_LE(s.local, limit) << what;
        }
    // Every compute unit has a group wherever there are items enough.
    EXPECT_GE(s.groups(), std::min(items, d.computeUnits)) << what;
    // Several groups per unit wherever the preferred multiple leaves room for them.
    const size_t multiple =
        std::clamp<size_t>(d.preferredMultiple, 1, std::min(maxWorkGroupSize(d), kMaxChosenWorkGroupSize));
    if (items >= d.computeUnits * kWorkGroupsPerComputeUnit * multiple) {
        EXPECT_GE(s.groups(), d.computeUnits * kWorkGroupsPerComputeUnit) << what;
    }
    // The preferred multiple is kept wherever the units are fed without going below it.
    if ((items + multiple - 1) / multiple >= d.computeUnits) {
        EXPECT_EQ(s.local % multiple, 0u) << what;
    }
}

}  // namespace

TEST(LaunchSize, TwoCoreCpuGetsManyGroupsOf256)
{
    // PoCL on this machine: 2 compute units, the kernel allows 4096, preferred multiple 8.
    const LaunchLimits cpu{2, 4096, 8, 4096, 4096};
    const LaunchSize s = chooseLaunchSize(128 * 128, cpu);
    EXPECT_EQ(s.local, 256u);
    EXPECT_EQ(s.global, 128u * 128u);
    EXPECT_EQ(s.groups(), 64u);
}

TEST(LaunchSize, GpuKeepsTheWarpMultipleAndFillsItsMultiprocessors)
{
    const LaunchLimits gpu{132, 1024, 32, 1024, 1024};
    const LaunchSize small = chooseLaunchSize(128 * 128, gpu);
    EXPECT_EQ(small.local, 32u);  // 512 groups; 64 would leave fewer than 8 per unit
    const LaunchSize large = chooseLaunchSize(1920 * 1080, gpu);
    EXPECT_EQ(large.local, 256u);
    EXPECT_EQ(large.global, (1920u * 1080u + 255u) / 256u * 256u);
}

TEST(LaunchSize, TinyImagesGoBelowThePreferredMultiple)
{
    const LaunchSize s = chooseLaunchSize(5, LaunchLimits{16, 4096, 8, 4096, 4096});
    EXPECT_EQ(s.local, 1u);
    EXPECT_EQ(s.global, 5u);
    const LaunchSize t = chooseLaunchSize(64, LaunchLimits{2, 4096, 64, 4096, 4096});
    EXPECT_EQ(t.groups(), 2u);  // 32 each: both units work
}

TEST(LaunchSize, KernelLimitBelowThePreferredMultiple)
{
    // A register-heavy kernel may allow fewer items than the warp: the limit wins.
    const LaunchSize s = chooseLaunchSize(100000, LaunchLimits{8, 16, 32, 1024, 1024});
    EXPECT_EQ(s.local, 16u);
}

TEST(LaunchSize, UnknownLimitsAndOddMultiples)
{
    const LaunchSize s = chooseLaunchSize(100000, LaunchLimits{4, 0, 0, 0, 0});
    EXPECT_EQ(s.local, 256u);
    const LaunchSize t = chooseLaunchSize(100000, LaunchLimits{4, 0, 12, 0, 0});
    EXPECT_EQ(t.local, 192u);  // 12 x 16
}

TEST(LaunchSize, EveryCombinationIsValid)
{
    for (size_t units : {1, 2, 3, 16, 132})
        for (size_t kernel : {0, 1, 7, 16, 64, 256, 1024, 4096})
            for (size_t multiple : {0, 1, 4, 8, 12, 32, 64})
                for (size_t device : {0, 128, 1024, 4096})
                    for (size_t items : {1, 2, 7, 100, 4096, 16384, 100003, 2073600})
                        expectValid(items, LaunchLimits{units, kernel, multiple, device, device});
}

// Bounded launches (LaunchPacer): the ranges and step budgets a pass is launched in.
TEST(LaunchPacer, RangesStartBalancedAndStayWithinTheStateBuffer)
{
    // A 2-core CPU, groups of 128, 1080p: the first range is 8 groups per core, the largest 2^16.
    LaunchPacer cpu(128, 2073600, 2, 0, 0);
    EXPECT_EQ(cpu.minItems, 2048u);
    EXPECT_EQ(cpu.maxItems, kMaxRangeItems);
    EXPECT_EQ(cpu.items, cpu.minItems);
    EXPECT_EQ(cpu.steps, kStartStepsPerSample);
    // A GPU of 132 units, groups of 256: 8 groups per unit are more than 2^16, and win.
    LaunchPacer gpu(256, 2073600, 132, 0, 0);
    EXPECT_EQ(gpu.minItems, 270336u);
    EXPECT_EQ(gpu.maxItems, 270336u);
    // A small image: one range of every item, a multiple of the group size.
    LaunchPacer small(64, 4096, 2, 0, 0);
    EXPECT_EQ(small.minItems, 1024u);
    EXPECT_EQ(small.maxItems, 4096u);
    for (const LaunchPacer& p : {cpu, gpu, small}) {
        EXPECT_EQ(p.minItems % p.unit, 0u);
        EXPECT_EQ(p.maxItems % p.unit, 0u);
        EXPECT_LE(p.minItems, p.maxItems);
    }
}

TEST(LaunchPacer, QuickLaunchesGrowTheRangeThenTheBudgetSlowOnesShrinkBoth)
{
    LaunchPacer p(128, 2073600, 2, 0, 0);
    const double quick = 0.1 * kTargetLaunchSeconds;
    p.update(quick, 0, true);
    EXPECT_EQ(p.items, 4096u);
    while (p.items < p.maxItems)
        p.update(quick, 10, true);
    EXPECT_EQ(p.steps, kStartStepsPerSample) << "the range grows first";
    p.update(quick, 10, true);
    EXPECT_EQ(p.steps, 2 * kStartStepsPerSample);
    EXPECT_EQ(p.rangeSteps, p.steps);
    p.update(quick, 0, true);
    EXPECT_EQ(p.steps, 2 * kStartStepsPerSample) << "no stopped paths: the budget is enough";

    // A launch 4x too long: both shrink 4x (the range to a multiple of the group, not below the minimum).
    p.update(4.0 * kTargetLaunchSeconds, 10, true);
    EXPECT_EQ(p.steps, kStartStepsPerSample / 2);
    EXPECT_EQ(p.items, kMaxRangeItems / 4);
    for (int i = 0; i < 20; ++i)
        p.update(100.0, 10, true);
    EXPECT_EQ(p.steps, 1);
    EXPECT_EQ(p.items, p.minItems);

    // The launches continuing a range grow their own budget; the next range starts from the range's.
    LaunchPacer q(128, 2073600, 2, 0, 0);
    q.startRange();
    q.update(0.5 * kTargetLaunchSeconds + 0.01, 100, true);  // neither quick nor slow
    q.update(quick, 3, false);
    q.update(quick, 1, false);
    EXPECT_EQ(q.steps, 4 * kStartStepsPerSample);
    EXPECT_EQ(q.rangeSteps, kStartStepsPerSample);
    q.startRange();
    EXPECT_EQ(q.steps, kStartStepsPerSample);
    q.update(quick, 3, false);
    q.update(2.0 * kTargetLaunchSeconds, 3, false);  // a slow continuation shrinks only its own
    EXPECT_EQ(q.steps, kStartStepsPerSample);
    EXPECT_EQ(q.rangeSteps, kStartStepsPerSample);
}

TEST(LaunchPacer, RequestedRangesAndBudgetsAreKept)
{
    LaunchPacer p(7, 1000, 2, 10, 3);  // ranges round up to the group size
    EXPECT_EQ(p.items, 14u);
    EXPECT_EQ(p.steps, 3);
    for (double seconds : {0.001, 100.0, 0.001})
        p.update(seconds, 5, true);
    EXPECT_EQ(p.items, 14u);
    EXPECT_EQ(p.steps, 3);
}
