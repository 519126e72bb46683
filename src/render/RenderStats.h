// RenderStats.h: what happened during a render (stage times, memory, counts), kept apart from
// the RenderPlan, which says what was decided before any heavy work. Printed by --explain after
// the plan. Index-aligned with the plan's lights and volumes.
#pragma once

#include "RenderPlan.h"

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace nimbus {

struct LightStats {
    int resolution = 0;  // the deep shadow map as built (texels per side)
    size_t shadowMapBytes = 0;
    double shadowMapSeconds = 0;
    size_t cacheBytes = 0;  // the shadow map baked on the voxels (LightCache)
    double cacheSeconds = 0;
    size_t marchSampleBytes = 0;      // the map's march samples the bake read (freed after), or 0
    size_t l2plusShadowMapBytes = 0;  // wkb: a shadow map of its own for the light volumes
    size_t skyBytes = 0;              // environment: its sky grid (SkyLight.h), single and wkb
    double skySeconds = 0;
};

struct VolumeStats {
    int mipLevels = 0;  // wkb light pyramid as built
    size_t pyramidBytes = 0;
    size_t bricks = 0;       // allocated density bricks
    size_t stiffBricks = 0;  // of those, stiff (StiffVoxels.h): single scattering sub-steps them
};

struct RenderStats {
    std::vector<std::pair<std::string, double>> stageSeconds;  // in the order they ran
    std::vector<LightStats> lights;
    std::vector<VolumeStats> volumes;
    size_t pyramidBytes = 0;  // wkb: all light pyramids as built
    // wkb: the orders-3+ cache as traced (vrl::Orders3Report): cells, skin cells, and the radius of
    // the sphere its light paths were aimed at (0: not aimed at the view).
    size_t orders3Cells = 0, orders3SkinCells = 0;
    float orders3FocusRadius = 0.0f;
    long long orders3Paths = 0, orders3MaxPaths = 0;  // traced; the adaptive count's cap (0: a fixed count)
    double orders3Noise = -1.0;                       // adaptive: the cache's measured relMSE in the image
    long long orders3NoisePaths = 0;                  // ... at this many paths
    int orders3FirstOrder = 3;  // the lowest scattering order the cache holds (2 with render.wkb_order2 "cache")
    bool orders3Blurred = true;                       // the cache blurred (the adaptive count may leave it sharp)
    // single, wkb: camera samples taken over the pixels marched (tiles that see no volume are not),
    // the pixels that took the most, and the base and most samples per pixel (AdaptiveSampling.h).
    long long cameraSamples = 0, marchedPixels = 0, pixelsAtMostSpp = 0;
    int baseSpp = 0, maxSpp = 0;

    void addStage(const std::string& name, double seconds) { stageSeconds.push_back({name, seconds}); }
    // The seconds of the named stage, or 0 if it did not run.
    double stage(const std::string& name) const;
    // Multi-line, human readable, after plan.describe() (names from the plan).
    std::string describe(const RenderPlan& plan) const;
};

}  // namespace nimbus
