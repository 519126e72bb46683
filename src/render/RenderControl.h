// RenderControl.h: the progress and cancel contract every integrator keeps (the engine's tile
// driver, the path tracer's launches). Here, below the integrators and the engine, so that each
// integrator can report progress and stop without including the engine.
//
// Cancel within a second (issue 18, item 3): progress is reported per tile, but a tile can take
// minutes (render.step = 1e-9 voxels, spp in the thousands), so the long loops inside a tile (every
// march's samples, the WKB l-march's nodes) poll a StopFlag as well and end early once it is
// raised; the driver then throws Cancelled and discards what they left. The stages before the
// tiles (deep shadow maps and their bakes, sky grids, WKB light volumes, the traced orders-3+
// cache) poll the same flag inside their loops and light-ray marches, whose length grows with
// render.shadow_step, the resolutions and the voxel count, and throw Cancelled themselves
// (throwIfStopped), so a cancel never waits for a whole stage either. So does the volumes' load
// before them (buildVolumes: the generators' blocks, resampling, between a volume's steps).
#pragma once

#include "../core/StopFlag.h"

#include <atomic>
#include <functional>

namespace nimbus {

struct RenderControl {
    // Called (possibly from worker threads) with the fraction done, in [0, 1]; return false to
    // cancel: the render then throws Cancelled.
    std::function<bool(float fraction)> progress;
    // Polled between units of work; true cancels the same way.
    const std::atomic<bool>* cancel = nullptr;

    // Reports `fraction` and says whether the render may go on.
    bool keepGoing(float fraction) const
    {
        if (progress && !progress(fraction))
            return false;
        return !(cancel && cancel->load(std::memory_order_relaxed));
    }
};

}  // namespace nimbus
