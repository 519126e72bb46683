#include "RenderContext.h"

#include "../core/Log.h"
#include "../scene/KernelScene.h"

#include <chrono>
#include <cmath>
#include <cstdio>

namespace nimbus {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Why light l cannot contribute to any volume, or empty if it can. Conservative: a light that
// might reach a volume is kept.
std::string unreachableReason(const Light& l, const NbLight& k, const Bbox& bounds)
{
    Rgb c = l.type == LightType::Distant ? l.irradiance
            : (l.type == LightType::Point || l.type == LightType::Spot) ? l.intensity
                                                                          : l.radiance;
    if (nbMaxComponent(c) <= 0.0f)
        return "zero power";
    if (bounds.empty())
        return "no volume to light";
    float3 centre = bounds.center();
    float radius = 0.5f * length(bounds.extent());
    if (l.type == LightType::Spot) {
        // Cone against the bounding sphere of the volumes.
        float3 toC = centre - l.position;
        float dist = length(toC);
        if (dist > radius) {
            float angleToCentre = std::acos(std::min(1.0f, std::max(-1.0f, dot(toC / dist, nbLoad3(k.direction)))));
            float halfCone = std::acos(std::min(1.0f, std::max(-1.0f, k.p0)));
            float sphereHalf = std::asin(std::min(1.0f, radius / dist));
            if (angleToCentre > halfCone + sphereHalf)
                return "spot cone misses every volume";
        }
    }
    if (l.type == LightType::Rect) {
        float3 n = nbLoad3(k.direction);
        if (dot(centre - l.center, n) < -radius)
            return "every volume is behind the emitting side";
    }
    return {};
}

// A distant light of apparent diameter `angle` blurs shadows by at most
// (distance through the volumes) * tan(angle / 2); when that stays under the finest voxel the
// blur is invisible and a shadow map of the disc's centre is exact to the grid's resolution.
bool sunSharperThanAVoxel(const Light& l, const VolumeSet& volumes)
{
    if (l.type != LightType::Distant || volumes.empty())
        return false;
    float across = length(volumes.worldBounds().extent());
    return across * std::tan(0.5 * l.angle * M_PI / 180.0) < volumes.minVoxelSize();
}

}  // namespace

std::unique_ptr<RenderContext> RenderContext::create(const Scene& scene, bool buildShadowMaps)
{
    auto ctx = std::make_unique<RenderContext>();
    ctx->scene = &scene;
    RenderPlan& plan = ctx->plan;
    plan.method = scene.render.method;

    auto t0 = std::chrono::steady_clock::now();
    ctx->volumes = VolumeSet(buildVolumes(scene), scene.render.step);
    plan.stageSeconds.push_back({"volumes", secondsSince(t0)});

    for (auto& v : ctx->volumes.volumes()) {
        VolumePlan vp;
        vp.name = v->name;
        vp.gridsRead = v->gridsRead;
        vp.emission = v->hasEmission();
        vp.bricks = v->density.brickCount() + v->emission.brickCount();
        vp.memoryBytes = v->density.memoryBytes() + v->emission.memoryBytes();
        vp.voxelSize = v->voxelSize;
        float maxSigma = nbMaxComponent(v->sigmaT()) * v->density.maxValue();
        vp.maxOpticalDepthPerVoxel = maxSigma * v->voxelSize;
        vp.opticalDepthAcross = maxSigma * length(v->worldBounds.extent());
        vp.clampedVoxels = v->clampedVoxels;
        char buf[160];
        std::snprintf(buf, sizeof buf, "[%.3g %.3g %.3g]-[%.3g %.3g %.3g] m", v->worldBounds.lo.x, v->worldBounds.lo.y,
                      v->worldBounds.lo.z, v->worldBounds.hi.x, v->worldBounds.hi.y, v->worldBounds.hi.z);
        vp.bounds = buf;
        plan.volumes.push_back(vp);
    }
    if (scene.volumes.size() > ctx->volumes.volumes().size())
        plan.notes.push_back(std::to_string(scene.volumes.size() - ctx->volumes.volumes().size()) +
                             " volume(s) empty after loading: skipped");
    if (!ctx->volumes.hasEmission())
        plan.notes.push_back("emission: off (no volume has an emission grid)");

    ctx->background = scene.background;
    bool hasEnvironment = false;
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        const Light& l = scene.lights[i];
        LightEntry e;
        e.light = makeNbLight(l, int(i));
        e.aov = "light_" + (l.name.empty() ? std::to_string(i) : l.name);
        LightPlan lp;
        lp.name = l.name.empty() ? std::to_string(i) : l.name;
        lp.type = lightTypeName(l.type);
        if (l.type == LightType::Environment) {
            if (!hasEnvironment)
                ctx->background = splat(0.0f);
            hasEnvironment = true;
            ctx->background += l.radiance;  // seen directly where rays leave the volumes (L0)
        }
        std::string why = unreachableReason(l, e.light, ctx->volumes.worldBounds());
        if (!why.empty()) {
            e.used = lp.used = false;
            lp.reason = why;
        } else if (nbLightIsDelta(e.light) || sunSharperThanAVoxel(l, ctx->volumes)) {
            e.delta = true;
            lp.shadowMap = true;
            if (!nbLightIsDelta(e.light))
                plan.notes.push_back("light " + lp.name + ": its " + std::to_string(l.angle) +
                                     " deg disc casts penumbrae under one voxel here: shadow-mapped as a point on the sky");
            lp.resolution = scene.render.shadowMapResolution;
            lp.projection = l.type == LightType::Distant ? "orthographic"
                            : (l.type == LightType::Spot && l.coneAngle <= 120.0f) ? "perspective"
                                                                                    : "cube";
        } else {
            lp.sampled = true;
            lp.reason = std::to_string(scene.render.lightSamples) + " sample(s) per step";
        }
        ctx->lights.push_back(std::move(e));
        plan.lights.push_back(lp);
    }

    if (buildShadowMaps) {
        auto t1 = std::chrono::steady_clock::now();
        DeepShadowMap::Settings s;
        s.resolution = scene.render.shadowMapResolution;
        s.tolerance = scene.render.tolerance;
        s.stepFraction = scene.render.shadowStep;
        s.keepMarchSamples = true;  // for the bake below, then released
        for (size_t i = 0; i < ctx->lights.size(); ++i) {
            if (!plan.lights[i].shadowMap)
                continue;
            ctx->lights[i].shadowMap = DeepShadowMap::build(ctx->lights[i].light, ctx->volumes, s);
            ctx->lights[i].cache = LightCache::bake(*ctx->lights[i].shadowMap, ctx->volumes);
            plan.lights[i].marchSampleBytes = ctx->lights[i].shadowMap->marchSampleBytes();
            ctx->lights[i].shadowMap->releaseMarchSamples();
            plan.lights[i].resolution = ctx->lights[i].shadowMap->resolution();
            plan.lights[i].shadowMapBytes = ctx->lights[i].shadowMap->memoryBytes();
            plan.lights[i].shadowMapSeconds = ctx->lights[i].shadowMap->buildSeconds();
            plan.lights[i].cacheBytes = ctx->lights[i].cache->memoryBytes();
            plan.lights[i].cacheSeconds = ctx->lights[i].cache->seconds();
        }
        plan.stageSeconds.push_back({"shadow maps", secondsSince(t1)});
    }
    return ctx;
}

Rgb RenderContext::deltaWeight(size_t i, float3 p, float3& wi) const
{
    const LightEntry& e = lights[i];
    if (e.light.type == NB_LIGHT_DISTANT) {  // also a soft sun shadow-mapped as its centre
        wi = -nbLoad3(e.light.direction);
        return nbLoad3(e.light.color);
    }
    NbLightSample s = nbLightSample(e.light, p, 0.5f, 0.5f);
    wi = s.wi;
    return s.weight;
}

Rgb RenderContext::incident(size_t i, float3 p, float u0, float u1, float3& wi, DeepShadowMap::Cursor* cursor) const
{
    const LightEntry& e = lights[i];
    NbLightSample s = nbLightSample(e.light, p, u0, u1);
    if (e.delta && e.light.type == NB_LIGHT_DISTANT) {
        s.wi = -nbLoad3(e.light.direction);
        s.weight = nbLoad3(e.light.color);
    }
    wi = s.wi;
    if (nbMaxComponent(s.weight) <= 0.0f)
        return splat(0.0f);
    if (e.shadowMap)
        return s.weight * e.shadowMap->transmittance(p, cursor);
    float tMax = std::min(s.distance, 1e30f);
    Rgb tau = volumes.opticalDepth(p, s.wi, 0.0f, tMax, scene->render.shadowStep);
    return s.weight * exp(-tau);
}

}  // namespace nimbus
