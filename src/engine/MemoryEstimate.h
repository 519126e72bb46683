// MemoryEstimate.h: the render's memory, known before it is spent (issue 18, item 4).
//
// The planning pass loads the volumes (the plan needs their bricks), so the estimate is made
// right after it and before every other large allocation: the film, the deep shadow maps and
// their bakes, the sky grids, the WKB light pyramids, the camera-ray batches and the path
// tracer's kernel buffers. What is already resident (code, libraries, the AX shader's JIT, the
// loaded volumes) is measured (/proc/self/statm), the rest estimated from the plan; the peak is
// the larger of the peak so far and resident + the rest. `nimbus info` prints it (RenderPlan's
// MemoryPlan); render() refuses, as bad input, a scene whose estimate exceeds
// render.memory_limit (bytes; 0, the default, is 80% of the physical memory or of the cgroup's
// limit, whichever is less). Accuracy against the measured peak: docs/benchmarks.md "Memory".
#pragma once

#include "../render/RenderPlan.h"

#include "../core/MemoryLimit.h"  // defaultMemoryLimit, memoryLimitBytes

#include <cstddef>

namespace nimbus {

struct RenderContext;

// Bytes resident now, and the most resident so far (Linux).
size_t residentBytes();
size_t peakResidentBytesSoFar();

// The estimate for the render the planning pass prepared (plan complete but for `memory`).
MemoryPlan estimateMemory(const Scene& scene, const RenderContext& ctx, const RenderPlan& plan);

// Throws the scene's InputError on render.memory_limit when the estimate exceeds the limit.
void checkMemoryLimit(const Scene& scene, const MemoryPlan& memory);

}  // namespace nimbus
