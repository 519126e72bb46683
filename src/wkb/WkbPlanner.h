// WkbPlanner.h: what the L2+ term of a scene needs, decided before any heavy work (DESIGN "leave
// out what a scene does not need"; issue 3 "render plan").
//
// Per light: how its L0 enters the light volumes (a delta-direction source E(y) from a deep shadow
// map, or spherical-harmonic coefficients of L0(y, n') for lights too wide to be a direction),
// and the SH order. Per volume: whether its L2+ share is above the tolerance, the light grid's
// voxel (a power-of-two multiple of the density voxel) and the pyramid's levels and memory. For
// the scene: whether L2+ is needed at all, with its bound (docs/wkb.md "render plan").
#pragma once

#include "../render/RenderContext.h"
#include "AngularKernel.h"

#include <string>
#include <vector>

namespace nimbus::wkb {

enum class SourceMode { Skip, Delta, Sh };

// One source of the light volumes: a scene light, or the volumes' own emission.
struct SourcePlan {
    SourceMode mode = SourceMode::Skip;
    int lightIndex = -1;  // in RenderContext::lights; -1 for emission
    bool emission = false;
    int order = 0;                   // SH order (mode Sh)
    // Read by the kernel's march, so kept in the light volumes: false for a light whose order 2
    // and orders 3+ are both traced (the radiance cache, TracedOrder2), which then has no channels
    // and no shadow map of its own there; emission always is.
    bool kernel = true;
    int offset = 0;                  // first channel in the light volumes
    int channelCount = 0;            // 3 (delta) or 3 (order+1)^2 (SH); 0 where !kernel
    NbLight light{};                 // as evaluated for E(y): may stand in for a small area light
    bool directional = false;        // delta source whose direction N is the same everywhere
    bool needsOwnShadowMap = false;  // delta source without a map in RenderContext
    std::string description;
};

struct VolumeSetup {
    bool l2plus = false;  // light channels built (else only the density channel, for the march)
    int factor = 2;       // light voxel = factor density voxels per axis
    // Light-grid voxel q sits at density index position origin + factor * q, origin the corner of
    // the density's brick table: the light grid's bricks then start where the active region does,
    // and its coarse levels merge into one brick instead of straddling index 0.
    float3 origin = make_float3(0, 0, 0);
    float lightVoxel = 0;  // world size of a level-0 light voxel, metres
    int channels = 1;
    int levels = 0;      // estimated, as bytes
    float maxSigma = 0;  // blur (level-0 voxels) at which the pyramid stops
    size_t bytes = 0;    // estimated (the build's figure is in RenderStats)
    double bound = 0;
};

// render.wkb_order2 "auto": order 2 from the traced radiance cache (cache true) unless some light's
// single scattering has an edge that the cache's cells would spread, where it is traced per camera
// ray: a spot light's cone edge, or a shadow caster's shadow edges. reason: why, for the plan's
// note (docs/wkb.md "Which order-2 model").
struct Order2Choice {
    bool cache = true;
    const char* reason = "";
};
Order2Choice chooseOrder2(const RenderContext& ctx);

// The plan's wkb part in full (RenderPlan::integrator), read by WkbIntegrator.
struct WkbSetup : IntegratorPlan {
    bool active = false;  // false: L2+ is zero for this scene (no volume, no light, or below tolerance)
    KernelType kernel = KernelType::Gaussian;
    bool randomWalk = false;
    // Order 2 of the light sources' L2+ by TracedOrder2 (a Monte Carlo sample per camera ray); the
    // kernel then drops its N = 1 term for them (docs/wkb.md "Order 2, traced").
    bool tracedOrder2 = true;
    // Orders 3+ of the light sources from the traced radiance cache (render.wkb_orders3 "traced"),
    // unless the medium is too thick per voxel for its light paths (kTracedOrders3MaxDepth) or
    // a volume moves by its transform within the shutter: the engine then builds no cache and the kernel keeps
    // them (docs/wkb.md "Orders 3 and up, traced").
    bool tracedOrders3 = false;
    // Order 2 of the light sources in the traced radiance cache too (render.wkb_order2 "cache",
    // where the cache is traced): its deposits start at the first scattering vertex.
    bool cachedOrder2 = false;
    float blurK = 24.0f, lStep = 0.25f, tolerance = 0.002f;
    int orderCap = 128;
    int channels = 1;
    // Some source is evaluated by the kernel's l-march (SourcePlan::kernel): only then are the
    // light volumes built and the l-march run (the lights traced, without emission: neither).
    bool kernelSources = true;
    double omegaMax = 0.0;  // largest albedo over volumes and channels
    std::vector<SourcePlan> sources;
    std::vector<VolumeSetup> volumes;  // index-aligned with RenderContext::volumes.volumes()
};

// The most optical depth across one density voxel (at the medium's largest extinction) for which
// the traced orders-3+ cache is built. Its light paths take a free flight per collision: past
// this, a conservative medium costs minutes (a box of 16 voxels at 1e4 per voxel and albedo 1:
// over 300 s for an 8x8 image, against 18 s at 100), and at extinctions near the top of the range
// the flights fall under float precision and a path stops advancing.
constexpr double kTracedOrders3MaxDepth = 1000.0;

// Plans L2+ for the context's scene and writes the decisions' summary into `plan` (plan.wkb, the
// wkb fields of plan.lights and plan.volumes): wkb's part of the engine's planning pass, before
// the shadow maps are built. Cheap: reads the brick tables, builds nothing.
WkbSetup planWkb(const RenderContext& ctx, RenderPlan& plan);

// The level-0 bricks of a light grid whose voxel is `factor` density voxels, with its origin at the
// corner of the density's brick table: the light bricks holding every active density brick's
// cells (the light grid follows the density's sparsity).
std::vector<Int3> lightGridBricks(const BrickGrid& density, int factor);
inline float3 lightGridOrigin(const BrickGrid& density)
{
    const Int3 lo = density.brickLo();
    return make_float3(float(lo.x * BrickGrid::kBrick), float(lo.y * BrickGrid::kBrick),
                       float(lo.z * BrickGrid::kBrick));
}

// Estimated memory of the pyramid of a volume with light-voxel factor `factor` and `channels`
// channels, and its level count (exposed for tests; the same rule LightPyramid::buildLevels uses).
size_t estimatePyramidBytes(const BrickGrid& density, int factor, int channels, float maxSigma, int* levels);

}  // namespace nimbus::wkb
