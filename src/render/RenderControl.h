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
// (throwIfStopped), so a cancel never waits for a whole stage either.
#pragma once

#include <atomic>
#include <functional>
#include <stdexcept>

namespace nimbus {

// Thrown by a render that was asked to stop (progress returned false, or cancel was set).
class Cancelled : public std::runtime_error {
public:
    Cancelled() : std::runtime_error("render cancelled") {}
};

// How often a march polls the StopFlag: every this many samples (a power of two). At tens of
// nanoseconds a sample, a few microseconds between polls; the poll's cost is lost in the sample's.
constexpr unsigned kStopPollInterval = 256;

// Raised once a render must stop: by the tile driver when progress returned false, or by the
// caller through the cancel flag it watches. Polled from worker threads in hot loops: each poll
// is one or two relaxed loads, and the loops poll every few hundred samples, not every sample.
class StopFlag {
public:
    // Also stop once `external` (the caller's cancel flag, RenderControl::cancel) is set.
    void watch(const std::atomic<bool>* external) { mExternal = external; }
    // Any thread may raise the flag, through a const context.
    void raise() const { mRaised.store(true, std::memory_order_relaxed); }
    bool raised() const
    {
        return mRaised.load(std::memory_order_relaxed) || (mExternal && mExternal->load(std::memory_order_relaxed));
    }

private:
    mutable std::atomic<bool> mRaised{false};
    const std::atomic<bool>* mExternal = nullptr;
};

// Whether `stop` (null: a build nobody can stop, a test's or a tool's) is raised.
inline bool stopRaised(const StopFlag* stop) { return stop && stop->raised(); }
// Ends a stage before the tiles once its render is stopped: what it built is discarded with it.
// Inside a TBB loop the exception ends the loop's other tasks and reaches the caller.
inline void throwIfStopped(const StopFlag* stop)
{
    if (stopRaised(stop))
        throw Cancelled();
}

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
