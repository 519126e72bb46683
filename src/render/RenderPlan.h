// RenderPlan.h: what a scene needs and what it can leave out, decided before any heavy work
// (DESIGN "leave out what a scene does not need"). Made once by the engine's planning pass
// (planPass in src/engine/Renderer.cpp: the shared part from RenderPlanner.h, then the integrator's own
// part), then immutable: integrators read it and never write it. What happens during the render
// goes to RenderStats. Printed by `nimbus info` and, with the stats, by --explain.
#pragma once

#include "../scene/Scene.h"

#include <memory>
#include <string>
#include <vector>

namespace nimbus {

struct LightPlan {
    std::string name;  // AOV suffix
    std::string type;
    bool used = true;        // false: skipped, with `reason`
    bool shadowMap = false;  // transmittance from a deep shadow map (delta lights)
    bool sampled = false;    // transmittance by shadow rays (area, sphere, soft sun)
    bool skyGrid = false;    // environment in single and wkb: SkyLight's grid, built once per render
    std::string projection;  // orthographic / perspective / cube
    int resolution = 0;      // the most texels per side; the build may use fewer (RenderStats)
    std::string reason;
    int motionKnots = 0;  // > 0: it moves within the shutter, by this many knots (motion.h)
    // wkb: how this light feeds L2+ (empty for other methods), e.g. "E = weight * T from the
    // deep shadow map" or "SH order 2 (27 channels)" or "skipped: <why>".
    std::string l2plus;
};

struct VolumePlan {
    std::string name;
    std::vector<std::string> gridsRead;
    bool emission = false;
    size_t bricks = 0;
    size_t memoryBytes = 0;
    float voxelSize = 0;
    float maxOpticalDepthPerVoxel = 0;  // max sigma_t * voxel size over channels
    float opticalDepthAcross = 0;       // max sigma_t * (bounding-box diagonal), an upper bound
    size_t clampedVoxels = 0;
    std::string bounds;
    // Velocity motion blur (docs/motion-blur.md): the vel grid read, its largest speed (index
    // voxels per second) and the largest displacement over the shutter (index voxels).
    int motionKnots = 0;  // > 0: its transform moves within the shutter, by this many knots (motion.h)
    bool velocity = false;
    float maxSpeed = 0;
    float maxDisplacement = 0;
    // wkb light pyramid (docs/wkb.md "render plan"):
    bool l2plus = false;       // light channels built for this volume
    double l2plusBound = 0;    // bound on this volume's share of L2+, in units of E / (4 pi)
    int lightVoxelFactor = 0;  // light-grid voxel = this many density voxels per axis
    int mipLevels = 0;         // estimated (the build's count is in RenderStats)
    std::string lightGrid;     // level-0 size, e.g. "20 x 14 x 18 voxels, 24 bricks"
    size_t pyramidBytes = 0;   // estimated
};

// One object of scene.geometry as loaded (docs/geometry.md).
struct GeometryPlan {
    std::string name, type;
    bool holdout = true, shadows = true;
    size_t triangles = 0;    // 0 for the analytic sphere and infinite plane
    std::string bounds;      // world space, "unbounded" for an infinite plane
    size_t memoryBytes = 0;  // its share of the world-space arrays
};

// The multiple-scattering term's choices (method wkb).
struct WkbPlan {
    bool enabled = false;    // method wkb
    bool l2plus = false;     // false: L2+ skipped for the whole scene (its bound is below tolerance)
    double l2plusBound = 0;  // bound on L2+ in units of the brightest source's E / (4 pi)
    std::string kernel, source;
    float blurK = 0, lStep = 0;
    int orderCap = 0;
    int channels = 0;  // per light-grid voxel: density + 3 per delta source + 3 (J+1)^2 per SH source
    bool lightGrid = true;  // light volumes built: false where every source is traced (no kernel source)
    size_t pyramidBytes = 0, densityBytes = 0;  // estimated light pyramids; the density grids
    float memoryBudget = 0;
};

// The render's memory, estimated before the large allocations (src/engine/MemoryEstimate.h).
struct MemoryPlan {
    struct Item {
        std::string name;  // e.g. "film", "deep shadow maps"
        size_t bytes = 0;
    };
    size_t residentBytes = 0;  // measured when estimated: code, libraries, the loaded volumes
    size_t peakSoFar = 0;      // the most resident before the estimate (the volume load's peak)
    std::vector<Item> items;   // what is still to be allocated
    size_t estimateBytes = 0;  // max(peakSoFar, residentBytes + sum of items)
    size_t limitBytes = 0;     // render.memory_limit, or its default
    bool limitDefault = true;  // the limit is the default fraction of physical memory
};

// An integrator's own decisions in full (wkb: WkbSetup, every source and light grid), made in the
// planning pass and read by the integrator; the printable summary is in the fields above.
struct IntegratorPlan {
    virtual ~IntegratorPlan() = default;
};

struct RenderPlan {
    Method method = Method::Single;
    std::vector<std::string> aovs;    // what the integrator writes, in output order (FilmLayout.h)
    std::vector<LightPlan> lights;    // index-aligned with scene.lights
    std::vector<VolumePlan> volumes;  // index-aligned with the loaded (non-empty) volumes
    WkbPlan wkb;
    std::vector<GeometryPlan> geometry;  // index-aligned with scene.geometry
    double geometryBvhSeconds = 0;       // building the Embree scenes (in the planning pass)
    size_t geometryBvhBytes = 0;         // Embree's allocations
    // The path tracer's tree (KernelBvh.h), where the planning pass built it (method pathtrace,
    // `nimbus info`): nodes, primitives, deepest leaf, bytes on the device, build seconds.
    bool kernelBvh = false;
    size_t kernelBvhNodes = 0, kernelBvhPrims = 0, kernelBvhBytes = 0;
    int kernelBvhDepth = 0;
    double kernelBvhSeconds = 0;
    std::string holdoutDepth;            // the depth-map holdout, described; empty: none
    MemoryPlan memory;
    std::vector<std::string> notes;                    // other omissions and decisions, one line each
    std::shared_ptr<const IntegratorPlan> integrator;  // null for integrators with no decisions of their own

    std::string describe() const;  // multi-line, human readable
};

}  // namespace nimbus
