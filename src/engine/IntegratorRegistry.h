// IntegratorRegistry.h: every integrator nimbus offers, one row each: what it produces (traits),
// its part of the planning pass, and how the engine makes it. Adding an integrator is a row in
// IntegratorRegistry.cpp and its own folder under src/ (docs/architecture.md).
#pragma once

#include "../render/Integrator.h"
#include "../render/RenderContext.h"
#include "../render/RenderPlan.h"
#include "../render/RenderStats.h"

#include <memory>

namespace nimbus {

struct RenderOptions;

struct IntegratorEntry {
    IntegratorTraits traits;
    // The integrator's own decisions, added to the shared plan in the planning pass (before any
    // shadow map is built); null where it has none.
    void (*plan)(const RenderContext& ctx, RenderPlan& plan) = nullptr;
    // Builds the integrator (its heavy precomputation, e.g. wkb's light volumes, recording sizes
    // and times in stats) once the context's shadow maps exist.
    std::unique_ptr<Integrator> (*create)(const RenderContext& ctx, const RenderPlan& plan,
                                          const RenderOptions& options, RenderStats& stats) = nullptr;
};

// The row of `method`. Throws std::logic_error for a method with no row (a registry bug).
const IntegratorEntry& integratorEntry(Method method);

}  // namespace nimbus
