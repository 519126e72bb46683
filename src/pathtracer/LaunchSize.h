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

}  // namespace nimbus
