// LaunchSize.h: the path tracer's OpenCL launch configuration (work-group size and global
// size), chosen from the device's and the kernel's properties so that every compute unit works.
//
// Why not let the runtime choose (a null local size): PoCL then picks the largest work-group
// its limit allows, and on a CPU one work-group runs on one thread from start to end. The path
// tracer's work items are pixels of very different cost (sky pixels are cheap, the cloud's core
// is not), so with a few huge groups the cores that draw cheap ones go idle: on a 2-core machine
// the path tracer kept 1.08 cores busy (docs/benchmarks.md, "The path tracer's launch").
// Splitting the image into several work-groups per compute unit lets the runtime hand them out
// as cores free up, on a CPU (PoCL's threads take groups from a queue) and on a GPU alike (each
// streaming multiprocessor takes groups until none is left).
#pragma once

#include <algorithm>
#include <cstddef>

namespace nimbus {

// The properties the choice depends on; 0 where the device did not say.
struct LaunchLimits {
    size_t computeUnits = 1;            // CL_DEVICE_MAX_COMPUTE_UNITS
    size_t kernelWorkGroupSize = 0;     // CL_KERNEL_WORK_GROUP_SIZE: this kernel on this device
    size_t preferredMultiple = 1;       // CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE (warp, SIMD width)
    size_t deviceMaxWorkGroupSize = 0;  // CL_DEVICE_MAX_WORK_GROUP_SIZE
    size_t deviceMaxWorkItemSize = 0;   // CL_DEVICE_MAX_WORK_ITEM_SIZES[0] (a 1-D launch)
};

struct LaunchSize {
    size_t local = 1;   // work-group size
    size_t global = 0;  // a multiple of local, at least the item count (OpenCL 1.2)
    size_t groups() const { return local > 0 ? global / local : 0; }
};

// Several work-groups per compute unit balance pixels of unequal cost; more would only add
// per-group overhead (small on both kinds of device).
constexpr size_t kWorkGroupsPerComputeUnit = 8;
// The largest work-group chosen: beyond it a CPU gains nothing and a GPU only loses occupancy.
constexpr size_t kMaxChosenWorkGroupSize = 256;

// The largest work-group size the kernel and the device allow (kMaxChosenWorkGroupSize where
// they say nothing).
inline size_t maxWorkGroupSize(const LaunchLimits& d)
{
    size_t m = 0;
    for (size_t v : {d.kernelWorkGroupSize, d.deviceMaxWorkGroupSize, d.deviceMaxWorkItemSize})
        if (v > 0)
            m = m > 0 ? std::min(m, v) : v;
    return m > 0 ? m : kMaxChosenWorkGroupSize;
}

// A launch of `items` work items (pixels): the local size is the preferred multiple times a
// power of two, as large as kMaxChosenWorkGroupSize and the limits allow while the items still
// make kWorkGroupsPerComputeUnit groups per compute unit; on images too small for that, smaller
// than the preferred multiple until every compute unit has a group (where there are items
// enough). A handful of possible local sizes also bounds the variants a runtime compiles
// (PoCL builds the kernel's work-group function per local size).
inline LaunchSize chooseLaunchSize(size_t items, const LaunchLimits& d)
{
    auto groupsOf = [items](size_t local) { return (items + local - 1) / local; };
    const size_t limit = std::min(maxWorkGroupSize(d), kMaxChosenWorkGroupSize);
    const size_t wanted = std::max<size_t>(1, d.computeUnits) * kWorkGroupsPerComputeUnit;
    size_t local = std::clamp<size_t>(d.preferredMultiple, 1, limit);
    while (local * 2 <= limit && groupsOf(local * 2) >= wanted)
        local *= 2;
    while (local > 1 && groupsOf(local) < std::max<size_t>(1, d.computeUnits))
        local /= 2;
    LaunchSize s;
    s.local = local;
    s.global = groupsOf(local) * local;
    return s;
}

// Launches of bounded length (kernels/pathtrace.cl): so that a cancel is seen within a second
// (issue 18, item 3) whatever one pixel sample costs (at an extinction of 2 x 10^5 1/m one sample
// of a 64x48 image took 43 s in one launch) and however many pixels there are, a pass over the
// image is a series of launches, each over a range of work items (a multiple of the work-group
// size, the group size itself unchanged: PoCL compiles the kernel once per size) in which every
// item may do a budget of steps per sample (flight starts, tentative collisions, shadow-ray
// steps: the kernel's units of work) before it saves its path and stops, between two flights or
// at a null collision; the next launch over the range continues the saved paths. The image is the
// same, bit for bit, whatever the ranges and budgets.

// Every launch aims at this length: well inside a second, long enough that a launch's overhead
// (~0.1 ms on PoCL) is noise.
constexpr double kTargetLaunchSeconds = 0.25;
// The most work items one launch covers where the device's 8 work-groups per compute unit are
// fewer (a CPU's: 2^16 saved paths are ~22 MiB); it sizes the saved paths' buffer.
constexpr size_t kMaxRangeItems = size_t(1) << 16;
// Steps per sample a launch allows at first, and at most. The first launch knows nothing of the
// scene, so it is short: a path of a cloud under a sun takes hundreds to a few thousand steps, and
// the budget doubles while launches are quick (4096 made the first launch of an extinction of
// 2 x 10^5 1/m last 0.29 s on an idle machine, over a second on a loaded one).
constexpr int kStartStepsPerSample = 1 << 9;
constexpr int kMaxStepsPerSample = 1 << 26;

// A bound on one saved path's bytes (the device reports the exact size of NbPathState): its sums
// (16 bytes a float3: three orders and one per light, and four floats), the cursor (the majorant
// walk, 96 bytes a volume, and ~100 more) and the rest, with alignment.
inline size_t pathStateBytesBound(size_t lights, size_t volumes) { return 16 * (lights + 4) + 112 * volumes + 256; }

// The range and the step budget of the next launch, from the length of the last. A range's first
// launch covers all its items; the launches that continue its stopped paths cover fewer and fewer
// (the slowest paths are the longest), so their budget is their own: it starts at the range's
// and grows while they are quick, and the next range starts again from the range budget. The
// first range has `minItems` (enough work-groups for every compute unit). Too long: smaller
// budgets (down to 1 step) and, after a range's first launch, a smaller range. Quick, after a
// range's first launch: a larger range, up to `maxItems`, then (where paths were stopped) a larger
// range budget. A launch of several samples per pixel that is too long leaves the budget alone:
// the pass's sample count comes down instead (Pathtracer.cpp), so ordinary paths are not stopped.
struct LaunchPacer {
    size_t unit = 1;      // ranges are multiples of it (the work-group size)
    size_t minItems = 1;  // a multiple of unit
    size_t maxItems = 1;  // a multiple of unit, at least minItems
    size_t items = 1;     // the next range's items
    int rangeSteps = kStartStepsPerSample;  // steps per sample of a range's first launch
    int steps = kStartStepsPerSample;       // steps per sample of the next launch
    bool fixedItems = false, fixedSteps = false;

    LaunchPacer(size_t unit_, size_t global, size_t computeUnits, size_t requestedItems, int requestedSteps)
        : unit(std::max<size_t>(1, unit_))
    {
        auto roundUp = [this](size_t n) { return (n + unit - 1) / unit * unit; };
        const size_t balanced = roundUp(unit * std::max<size_t>(1, computeUnits) * kWorkGroupsPerComputeUnit);
        maxItems = std::max(unit, std::min(roundUp(global), std::max(balanced, kMaxRangeItems / unit * unit)));
        minItems = std::min(maxItems, balanced);
        items = minItems;
        if (requestedItems > 0) {
            items = std::clamp(roundUp(requestedItems), unit, maxItems);
            fixedItems = true;
        }
        if (requestedSteps > 0) {
            rangeSteps = steps = requestedSteps;
            fixedSteps = true;
        }
    }

    // Before a range's first launch.
    void startRange() { steps = rangeSteps; }

    // After a launch of `seconds` and `samples` per pixel that stopped `suspended` paths; `first`:
    // the range's first.
    void update(double seconds, long long suspended, bool first, int samples = 1)
    {
        if (seconds > kTargetLaunchSeconds) {
            const double shrink = std::max(0.1, kTargetLaunchSeconds / seconds);
            if (!fixedSteps && samples <= 1)
                steps = std::max(1, int(double(steps) * shrink));
            if (first && !fixedItems)
                items = std::max(minItems, size_t(double(items) * shrink) / unit * unit);
            if (first)
                rangeSteps = steps;
        } else if (seconds < 0.5 * kTargetLaunchSeconds && suspended > 0 && !fixedSteps) {
            if (!first)
                steps = std::min(kMaxStepsPerSample, 2 * steps);
            else if (fixedItems || items >= maxItems)
                rangeSteps = steps = std::min(kMaxStepsPerSample, 2 * steps);
        }
        if (first && seconds < 0.5 * kTargetLaunchSeconds && !fixedItems && items < maxItems)
            items = std::min(maxItems, 2 * items);
    }
};

}  // namespace nimbus
