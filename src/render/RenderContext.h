// RenderContext.h: everything an integrator reads besides the plan, built once from a Scene and
// its RenderPlan: the volumes as one medium, the lights in kernel form and their deep shadow maps.
#pragma once

#include "../geometry/EmbreeScene.h"
#include "../geometry/HoldoutDepth.h"
#include "../geometry/KernelBvh.h"
#include "../scene/KernelScene.h"
#include "../scene/Scene.h"
#include "DeepShadowMap.h"
#include "LightCache.h"
#include "RenderControl.h"
#include "RenderPlan.h"
#include "RenderStats.h"
#include "SkyLight.h"
#include "StiffVoxels.h"
#include "VolumeSet.h"

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace nimbus {

class ShadowMapCache;

struct LightEntry {
    NbLight light;  // at the shutter's centre (Light's static values)
    // Motion within the shutter (kernels/shared/motion.h knots, seconds after the frame's);
    // empty: still. lightAt places the light at a shutter time.
    std::vector<float> motion;
    NbLight lightAt(float seconds) const
    {
        return motion.empty() ? light
                              : nbLightAt(light, motion.data(), int(motion.size() / NB_MOTION_KNOT), seconds);
    }
    std::string aov;  // "light_<name>"
    bool used = true;
    // One fixed sample per step suffices: a delta light, or a distant light whose penumbra
    // across the whole volume is under a voxel (then its disc is treated as its centre).
    bool delta = false;
    std::optional<DeepShadowMap> shadowMap;  // set for delta lights that reach a volume
    std::optional<LightCache> cache;         // the shadow map baked on the voxels
    // environment: its HDR map (null: uniform) and, in single and wkb, its sky grid (the plan's
    // skyGrid; built by buildShadowMaps): the marches read it instead of sampling the light.
    std::shared_ptr<const EnvironmentMap> map;
    std::optional<SkyLight> sky;
};

struct RenderContext {
    const Scene* scene = nullptr;
    VolumeSet volumes;
    std::vector<LightEntry> lights;  // index-aligned with scene.lights
    std::vector<StiffVoxels> stiff;  // per volume: bricks with optically thick voxels (StiffVoxels.h)
    Rgb background = splat(0.0f);    // radiance seen where rays leave the volumes, less the maps'
    // The radiance a ray leaving the volumes along unit direction d sees: background plus every
    // environment map's colour * map(d).
    Rgb backgroundAlong(float3 d) const
    {
        Rgb b = background;
        for (const LightEntry& e : lights)
            if (e.map)
                b += nbLoad3(e.light.color) * e.map->lookup(d);
        return b;
    }
    // Whether the background depends on the direction (an environment map).
    bool backgroundVaries() const
    {
        for (const LightEntry& e : lights)
            if (e.map)
                return true;
        return false;
    }
    // Scene geometry (docs/geometry.md): null where the scene has none (no Embree device is made).
    std::shared_ptr<const EmbreeScene> geometry;
    std::shared_ptr<const HoldoutDepth> holdoutDepth;  // camera.holdout_depth; null where none
    // The path tracer's tree of the geometry (KernelBvh.h), built in the planning pass for method
    // pathtrace and for `nimbus info`; null otherwise (single and wkb trace through Embree).
    std::shared_ptr<const KernelBvh> kernelBvh;
    // Raised when the render must stop (RenderControl.h): the marches poll it inside tiles and
    // return early, leaving partial samples the driver discards.
    StopFlag stop;

    // Whether camera rays can be held out (a holdout object or a depth map): the tile driver
    // then clips each camera ray at its first holdout.
    bool hasCameraHoldouts() const { return (geometry && geometry->hasHoldouts()) || holdoutDepth; }
    // The shadow casters, or null: what deep shadow maps and shadow rays stop at.
    const EmbreeScene* shadowCasters() const
    {
        return geometry && geometry->hasShadowCasters() ? geometry.get() : nullptr;
    }

    // The context for `plan` (made by planScene over the same volumes): the lights in kernel
    // form, used and shadow-mapped as the plan says; the scene's geometry loaded and its Embree
    // scenes built, the depth-map holdout read (both throw InputError for bad files); no shadow
    // map built yet.
    static std::unique_ptr<RenderContext> create(const Scene& scene, VolumeSet volumes, const RenderPlan& plan);
    // Loads the volumes, plans the shared part (planScene) and, if asked, builds the shadow maps:
    // for tests and tools that march rays themselves. Renders go through the engine.
    static std::unique_ptr<RenderContext> create(const Scene& scene, bool buildShadowMaps);

    // The plan's deep shadow maps (delta lights that reach a volume), each baked on the voxels,
    // and the sky grids of its environment lights (skyGrid);
    // sizes and times go to stats. With a cache, a light's map from the last frame is reused
    // where nothing it depends on changed (ShadowMapCache.h).
    void buildShadowMaps(const RenderPlan& plan, RenderStats& stats, ShadowMapCache* cache = nullptr);
    // The sky grids' settings from the scene's render keys (SkyLight.h).
    SkyLight::Settings skySettings() const;

    // Transmittance-weighted light arriving at p from light i, as L_i / pdf (see light.h), and
    // the direction toward the light. Uses the shadow map where there is one, else a shadow ray.
    // L_i / pdf for a light treated as a delta (one fixed sample), before transmittance, and
    // the direction toward it.
    // seconds: the ray's shutter time, at which a moving light is placed (LightEntry::lightAt).
    Rgb deltaWeight(size_t i, float3 p, float3& wi, float seconds = 0.0f) const;

    // `cursor`, if given, speeds up shadow-map lookups along one ray. seconds: as deltaWeight's;
    // shadowPoint: where the shadow map (or shadow ray) is read, p where null (moving volumes:
    // VolumeSet::sampleAt's lightPoint). A moving light's map is the shutter centre's.
    Rgb incident(size_t i, float3 p, float u0, float u1, float3& wi, DeepShadowMap::Cursor* cursor = nullptr,
                 float seconds = 0.0f, const float3* shadowPoint = nullptr) const;
    // Whether some light moves within the shutter.
    bool lightsMove() const
    {
        for (const LightEntry& e : lights)
            if (!e.motion.empty())
                return true;
        return false;
    }
    // Whether anything the marches read moves within the shutter (volumes or lights): then each
    // camera sample's time is passed down and the general march runs.
    bool moving() const { return volumes.moving() || lightsMove(); }
};

}  // namespace nimbus
