// RenderPlanner.h: the shared part of the planning pass: per volume what was loaded and how
// thick it is, per light whether it can reach a volume and how its transmittance is found (a
// deep shadow map, or shadow rays). Pure: reads the scene and the loaded volumes, builds nothing.
// The engine adds the integrator's own part (planPass in src/engine/Renderer.cpp).
#pragma once

#include "RenderPlan.h"
#include "VolumeSet.h"

namespace nimbus {

RenderPlan planScene(const Scene& scene, const VolumeSet& volumes);

struct RenderContext;
// The geometry's part of the plan, once the context has loaded it: each object, the BVH's build
// time and memory, the depth-map holdout (`nimbus info` prints them).
void planGeometry(const RenderContext& ctx, RenderPlan& plan);

}  // namespace nimbus
