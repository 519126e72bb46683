// StopFlag.h: how a long computation learns that its render was cancelled (Cancelled, StopFlag,
// throwIfStopped). In core, below every layer that polls it: the volumes' load (generators,
// resampling) as well as the render stages and integrators (render/RenderControl.h, the
// progress and cancel contract built on it).
#pragma once

#include <atomic>
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

}  // namespace nimbus
