// MemoryLimit.h: the bytes a render may use (render.memory_limit, issue 18 item 4), in core so
// that the volumes' load can check what a step would allocate before it does (VdbLoad.cpp's
// resampling) as the render's estimate does after the load (engine/MemoryEstimate.h).
#pragma once

#include <cstddef>

namespace nimbus {

// 80% of min(MemTotal, cgroup memory.max): the default render.memory_limit.
size_t defaultMemoryLimit();

// render.memory_limit in bytes: `configured` where it is set (> 0), else the default.
size_t memoryLimitBytes(double configured);

}  // namespace nimbus
