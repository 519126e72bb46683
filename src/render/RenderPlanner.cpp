#include "RenderPlanner.h"

#include "RenderContext.h"

#include "../scene/KernelScene.h"

#include <cmath>
#include <cstdio>

namespace nimbus {

namespace {

// Why light l cannot contribute to any volume, or empty if it can. Conservative: a light that
// might reach a volume is kept.
std::string unreachableReason(const Light& l, const NbLight& k, const Bbox& bounds)
{
    Rgb c = l.type == LightType::Distant                                ? l.irradiance
            : (l.type == LightType::Point || l.type == LightType::Spot) ? l.intensity
                                                                        : l.radiance;
    if (nbMaxComponent(c) <= 0.0f)
        return "zero power";
    if (bounds.empty())
        return "no volume to light";
    if (!l.shutterMotion.frames.empty())
        return {};  // it moves within the shutter: its placement at the centre does not decide
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

// A distant light's disc up to this apparent diameter is shadow-mapped with its penumbra filtered
// over the map (DeepShadowMap::penumbraTexels: parallel rays across a disc, an approximation that
// holds for small angles); wider ones are sampled with shadow rays at every step.
constexpr float kFilteredSunMaxAngleDeg = 5.0f;

std::string shortNumber(double v)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
}

}  // namespace

RenderPlan planScene(const Scene& scene, const VolumeSet& volumes)
{
    RenderPlan plan;
    plan.method = scene.render.method;
    for (auto& v : volumes.volumes()) {
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
        vp.motionKnots = volumes.transformKnots(plan.volumes.size());
        vp.velocity = v->hasVelocity();
        vp.maxSpeed = v->maxSpeed;
        vp.maxDisplacement = volumes.maxDisplacement(plan.volumes.size());
        char buf[160];
        std::snprintf(buf, sizeof buf, "[%.3g %.3g %.3g]-[%.3g %.3g %.3g] m", v->worldBounds.lo.x, v->worldBounds.lo.y,
                      v->worldBounds.lo.z, v->worldBounds.hi.x, v->worldBounds.hi.y, v->worldBounds.hi.z);
        vp.bounds = buf;
        plan.volumes.push_back(vp);
    }
    if (scene.volumes.size() > volumes.volumes().size())
        plan.notes.push_back(std::to_string(scene.volumes.size() - volumes.volumes().size()) +
                             " volume(s) empty after loading: skipped");
    if (!volumes.hasEmission())
        plan.notes.push_back("emission: off (no volume has an emission grid)");

    for (size_t i = 0; i < scene.lights.size(); ++i) {
        const Light& l = scene.lights[i];
        const NbLight k = makeNbLight(l, int(i));
        LightPlan lp;
        lp.name = l.name.empty() ? std::to_string(i) : l.name;
        lp.type = lightTypeName(l.type);
        lp.motionKnots = int(l.shutterMotion.frames.size());
        std::string why = unreachableReason(l, k, volumes.movingBounds());
        if (!why.empty()) {
            lp.used = false;
            lp.reason = why;
        } else if (nbLightIsDelta(k) || sunSharperThanAVoxel(l, volumes) ||
                   (l.type == LightType::Distant && l.angle <= kFilteredSunMaxAngleDeg)) {
            lp.shadowMap = true;
            if (!nbLightIsDelta(k))
                plan.notes.push_back("light " + lp.name + ": its " + shortNumber(l.angle) +
                                     " deg disc: shadow-mapped, its penumbrae filtered over the map where wider than "
                                     "half a texel (discs up to " +
                                     shortNumber(kFilteredSunMaxAngleDeg) +
                                     " deg, or with penumbrae under a voxel; wider discs are sampled)");
            lp.resolution = scene.render.shadowMapResolution;
            lp.projection = l.type == LightType::Distant                           ? "orthographic"
                            : (l.type == LightType::Spot && l.coneAngle <= 120.0f) ? "perspective"
                                                                                   : "cube";
        } else if (l.type == LightType::Environment && !isProgressive(scene.render.method)) {
            lp.skyGrid = true;
            lp.reason = "SH order " + std::to_string(scene.render.wkbShOrderMax) + ", " +
                        std::to_string(skyNodesAcross(scene)) + " nodes across each volume, " +
                        std::to_string(SkyLight::kCellRows * SkyLight::kCellColumns) + " sky cells" +
                        (l.map.empty() ? std::string(", uniform") : ", map '" + l.map + "'");
        } else {
            lp.sampled = true;
            lp.reason = l.type == LightType::Environment && !l.map.empty()
                            ? "map '" + l.map + "', importance-sampled with MIS against the phase function"
                            : std::to_string(scene.render.lightSamples) + " sample(s) per step";
        }
        plan.lights.push_back(lp);
    }
    return plan;
}

void planGeometry(const RenderContext& ctx, RenderPlan& plan)
{
    plan.geometry.clear();
    if (ctx.geometry) {
        for (const GeometryObject& o : ctx.geometry->geometry().objects()) {
            GeometryPlan gp;
            gp.name = o.name;
            gp.type = geometryTypeName(o.type);
            gp.holdout = o.holdout;
            gp.shadows = o.shadows;
            gp.triangles = o.triangleCount;
            gp.memoryBytes = o.memoryBytes;
            char buf[160];
            if (o.bounds.empty())
                std::snprintf(buf, sizeof buf, "unbounded");
            else
                std::snprintf(buf, sizeof buf, "[%.3g %.3g %.3g]-[%.3g %.3g %.3g] m", o.bounds.lo.x, o.bounds.lo.y,
                              o.bounds.lo.z, o.bounds.hi.x, o.bounds.hi.y, o.bounds.hi.z);
            gp.bounds = buf;
            plan.geometry.push_back(gp);
        }
        plan.geometryBvhSeconds = ctx.geometry->buildSeconds();
        plan.geometryBvhBytes = ctx.geometry->bvhBytes();
        if (ctx.kernelBvh) {
            plan.kernelBvh = true;
            plan.kernelBvhNodes = ctx.kernelBvh->nodes.size();
            plan.kernelBvhPrims = ctx.kernelBvh->prims.size();
            plan.kernelBvhBytes = ctx.kernelBvh->memoryBytes();
            plan.kernelBvhDepth = ctx.kernelBvh->depth;
            plan.kernelBvhSeconds = ctx.kernelBvh->buildSeconds;
        }
    }
    if (ctx.holdoutDepth)
        plan.holdoutDepth = ctx.scene->camera.holdoutDepth.file + ", channel " + ctx.scene->camera.holdoutDepth.channel +
                            ", " + std::to_string(ctx.holdoutDepth->width()) + "x" +
                            std::to_string(ctx.holdoutDepth->height()) + " (camera-space Z)";
}

}  // namespace nimbus
