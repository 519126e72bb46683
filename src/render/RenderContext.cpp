#include "RenderContext.h"

#include "ShadowMapCache.h"

#include "FilmLayout.h"
#include "RenderPlanner.h"

#include "../scene/KernelScene.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace nimbus {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

std::unique_ptr<RenderContext> RenderContext::create(const Scene& scene, VolumeSet volumes, const RenderPlan& plan)
{
    auto ctx = std::make_unique<RenderContext>();
    ctx->scene = &scene;
    ctx->volumes = std::move(volumes);
    ctx->background = scene.background;
    // Geometry only where the scene has some: otherwise no Embree device exists at all.
    if (!scene.geometry.empty())
        ctx->geometry = std::make_shared<const EmbreeScene>(GeometrySet::load(scene));
    ctx->holdoutDepth = HoldoutDepth::load(scene);
    for (const auto& v : ctx->volumes.volumes())
        ctx->stiff.push_back(StiffVoxels::find(*v, scene.render.step * v->voxelSize));
    bool hasEnvironment = false;
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        const Light& l = scene.lights[i];
        LightEntry e;
        e.light = makeNbLight(l, int(i));
        e.motion = lightMotionKnots(l, scene.render.fps);
        e.aov = lightAovName(l, i);
        if (l.type == LightType::Environment) {
            if (!hasEnvironment)
                ctx->background = splat(0.0f);
            hasEnvironment = true;
            e.map = EnvironmentMap::load(scene, i);  // InputError for a bad map
            if (!e.map)
                ctx->background += nbLoad3(e.light.color);  // seen directly where rays leave the volumes (L0)
        }
        e.used = plan.lights[i].used;
        e.delta = plan.lights[i].shadowMap;
        ctx->lights.push_back(std::move(e));
    }
    return ctx;
}

std::unique_ptr<RenderContext> RenderContext::create(const Scene& scene, bool buildShadowMaps)
{
    VolumeSet volumes(buildVolumes(scene), scene.render.step);
    setShutterOf(volumes, scene);
    const RenderPlan plan = planScene(scene, volumes);
    auto ctx = create(scene, std::move(volumes), plan);
    if (buildShadowMaps) {
        RenderStats stats;
        ctx->buildShadowMaps(plan, stats);
    }
    return ctx;
}

void RenderContext::buildShadowMaps(const RenderPlan& plan, RenderStats& stats, ShadowMapCache* cache)
{
    auto t1 = std::chrono::steady_clock::now();
    const Scene& s0 = *scene;
    DeepShadowMap::Settings s;
    s.resolution = s0.render.shadowMapResolution;
    s.tolerance = s0.render.tolerance;
    s.stepFraction = s0.render.shadowStep;
    s.keepMarchSamples = true;  // for the bake below, then released
    s.shadowCasters = shadowCasters();
    s.stop = &stop;  // the builds below throw Cancelled once the render is stopped
    stats.lights.resize(lights.size());
    for (size_t i = 0; i < lights.size(); ++i) {
        if (!plan.lights[i].shadowMap)
            continue;
        LightStats& ls = stats.lights[i];
        if (cache && cache->take(*this, i)) {  // the last frame's, unchanged (ShadowMapCache.h)
            ls.resolution = lights[i].shadowMap->resolution();
            ls.shadowMapBytes = lights[i].shadowMap->memoryBytes();
            ls.cacheBytes = lights[i].cache->memoryBytes();
            continue;
        }
        // A soft sun's disc: its penumbrae filtered over the map (DeepShadowMap::penumbraTexels).
        const NbLight& nl = lights[i].light;
        s.penumbraSlope = nl.type == NB_LIGHT_DISTANT && nl.p0 < 1.0f && nl.p0 > 0.0f
                              ? std::sqrt(std::max(0.0f, 1.0f - nl.p0 * nl.p0)) / nl.p0
                              : 0.0f;
        lights[i].shadowMap = DeepShadowMap::build(lights[i].light, volumes, s);
        lights[i].cache = LightCache::bake(*lights[i].shadowMap, volumes, &stop);
        ls.marchSampleBytes = lights[i].shadowMap->marchSampleBytes();
        lights[i].shadowMap->releaseMarchSamples();
        ls.resolution = lights[i].shadowMap->resolution();
        ls.shadowMapBytes = lights[i].shadowMap->memoryBytes();
        ls.shadowMapSeconds = lights[i].shadowMap->buildSeconds();
        ls.cacheBytes = lights[i].cache->memoryBytes();
        ls.cacheSeconds = lights[i].cache->seconds();
    }
    if (stats.volumes.size() < stiff.size())
        stats.volumes.resize(stiff.size());
    for (size_t v = 0; v < stiff.size(); ++v) {
        stats.volumes[v].bricks = volumes.volumes()[v]->density.brickCount();  // subSteps: empty if none stiff
        stats.volumes[v].stiffBricks = size_t(std::count_if(stiff[v].subSteps.begin(), stiff[v].subSteps.end(),
                                                            [](uint8_t n) { return n > 0; }));
    }
    stats.addStage("shadow maps", secondsSince(t1));
    auto t2 = std::chrono::steady_clock::now();
    bool anySky = false;
    for (size_t i = 0; i < lights.size(); ++i) {
        if (!plan.lights[i].skyGrid || !plan.lights[i].used)
            continue;
        const SkyLight::Settings ss = skySettings();
        anySky = true;
        if (cache && cache->takeSky(*this, i, ss)) {  // the last frame's, unchanged (ShadowMapCache.h)
            stats.lights[i].skyBytes = lights[i].sky->memoryBytes();
            continue;
        }
        lights[i].sky =
            SkyLight::build(volumes, shadowCasters(), lights[i].map.get(), nbLoad3(lights[i].light.color), ss, &stop);
        stats.lights[i].skyBytes = lights[i].sky->memoryBytes();
        stats.lights[i].skySeconds = lights[i].sky->buildSeconds();
    }
    if (anySky)
        stats.addStage("sky grid", secondsSince(t2));
}

SkyLight::Settings RenderContext::skySettings() const
{
    SkyLight::Settings ss;
    ss.order = scene->render.wkbShOrderMax;
    ss.nodesAcross = skyNodesAcross(*scene);
    ss.shadowStep = scene->render.shadowStep;
    if (scene->camera.width > 0 && scene->camera.height > 0) {
        const NbCamera nc = makeNbCamera(scene->camera);
        float3 d;
        nbCameraRay(nc, 0.5f * float(scene->camera.width), 0.5f * float(scene->camera.height), scene->camera.width,
                    scene->camera.height, 0.5f, &ss.viewer, &d);
        ss.hasViewer = true;
    }
    return ss;
}

Rgb RenderContext::deltaWeight(size_t i, float3 p, float3& wi, float seconds) const
{
    const NbLight light = lights[i].lightAt(seconds);
    if (light.type == NB_LIGHT_DISTANT) {  // also a soft sun shadow-mapped as its centre
        wi = -nbLoad3(light.direction);
        return nbLoad3(light.color);
    }
    NbLightSample s = nbLightSample(light, p, 0.5f, 0.5f);
    wi = s.wi;
    return s.weight;
}

Rgb RenderContext::incident(size_t i, float3 p, float u0, float u1, float3& wi, DeepShadowMap::Cursor* cursor,
                            float seconds, const float3* shadowPoint) const
{
    const LightEntry& e = lights[i];
    const NbLight light = e.lightAt(seconds);
    NbLightSample s = nbLightSample(light, p, u0, u1);
    if (e.delta && light.type == NB_LIGHT_DISTANT) {
        s.wi = -nbLoad3(light.direction);
        s.weight = nbLoad3(light.color);
    }
    wi = s.wi;
    if (nbMaxComponent(s.weight) <= 0.0f)
        return splat(0.0f);
    const float3 q = shadowPoint ? *shadowPoint : p;
    if (e.shadowMap)
        return s.weight * e.shadowMap->transmittance(q, cursor);
    float tMax = std::min(s.distance, 1e30f);
    if (const EmbreeScene* casters = shadowCasters())
        if (casters->occluded(q, s.wi, 0.0f, tMax))
            return splat(0.0f);
    Rgb tau = volumes.opticalDepth(q, s.wi, 0.0f, tMax, scene->render.shadowStep, &stop);
    return s.weight * exp(-tau);
}

}  // namespace nimbus
