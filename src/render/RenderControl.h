// RenderControl.h: the progress and cancel contract every integrator keeps (the engine's tile
// driver, the path tracer's launches). Here, below the integrators and the engine, so that each
// integrator can report progress and stop without including the engine.
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
