#include "LightVolumes.h"

#include "../../kernels/shared/rng.h"
#include "../render/SphericalHarmonics.h"
#include "../single/EmissionScatter.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace nimbus::wkb {

namespace {

constexpr int kS = BrickGrid::kStored;
// Light samples per voxel for an SH source, and directions per voxel for emission (even): a
// stratified (Fibonacci) set of antithetic pairs, shifted per voxel so that neighbouring voxels do
// not share its pattern.
constexpr int kShSamples = 32;
constexpr int kEmissionDirections = 32;
constexpr float kGoldenFraction = 0.61803398875f;

double secondsSince(std::chrono::steady_clock::time_point t)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

float fract(float x)
{
    return x - std::floor(x);
}

}  // namespace

Rgb LightVolumes::deltaE(const SourcePlan& source, size_t sourceIndex, float3 y, float rMin) const
{
    Rgb weight;
    if (source.directional) {
        weight = nbLoad3(source.light.color);  // irradiance on a surface facing the sun
    } else {
        NbLightSample s = nbLightSample(source.light, y, 0.5f, 0.5f);
        weight = s.weight;
        // Point-like sources: 1/r^2 averaged over a light voxel stays finite (a light inside the
        // volume); flooring r at half a voxel keeps E(y) from growing without bound.
        float3 d = y - nbLoad3(source.light.position);
        float r2 = dot(d, d);
        if (r2 < rMin * rMin)
            weight = weight * (r2 / (rMin * rMin));
    }
    if (nbMaxComponent(weight) <= 0.0f)
        return splat(0.0f);
    if (!source.needsOwnShadowMap && source.lightIndex >= 0) {
        const LightEntry& e = mCtx->lights[size_t(source.lightIndex)];
        if (e.cache) {
            const auto& vols = mCtx->volumes.volumes();
            thread_local std::vector<BrickGrid::Stencil> stencils;
            stencils.resize(vols.size());
            bool inside = false;
            for (size_t v = 0; v < vols.size(); ++v) {
                stencils[v] = vols[v]->density.stencil(vols[v]->indexFromWorld.point(y));
                inside |= stencils[v].brick >= 0;
            }
            if (inside)
                return weight * e.cache->transmittance(stencils.data());
        }
    }
    const DeepShadowMap* map = mMaps[sourceIndex];
    return map ? weight * map->transmittance(y) : weight;
}

float3 LightVolumes::deltaDirection(const SourcePlan& source, float3 y)
{
    if (source.directional)
        return normalize(nbLoad3(source.light.direction));
    float3 d = y - nbLoad3(source.light.position);
    float r = length(d);
    return r > 0.0f ? d / r : make_float3(0, -1, 0);
}

size_t LightVolumes::memoryBytes() const
{
    size_t b = 0;
    for (const LightPyramid& p : mPyramids)
        b += p.memoryBytes();
    return b;
}

void LightVolumes::build(const RenderContext& ctx, const WkbSetup& setup, RenderStats& stats)
{
    mCtx = &ctx;
    mPyramids.assign(setup.volumes.size(), LightPyramid());
    mOwnMaps.clear();
    mOwnMaps.resize(setup.sources.size());
    mMaps.assign(setup.sources.size(), nullptr);
    if (!setup.active || !setup.kernelSources)
        return;  // nothing reads them: every source is traced (WkbPlanner)
    auto t0 = std::chrono::steady_clock::now();
    DeepShadowMap::Settings dsm;
    dsm.resolution = ctx.scene->render.shadowMapResolution;
    dsm.tolerance = ctx.scene->render.tolerance;
    dsm.stepFraction = ctx.scene->render.shadowStep;
    dsm.shadowCasters = ctx.shadowCasters();
    dsm.stop = &ctx.stop;  // the builds here throw Cancelled once the render is stopped
    for (size_t i = 0; i < setup.sources.size(); ++i) {
        const SourcePlan& sp = setup.sources[i];
        if (sp.mode != SourceMode::Delta || !sp.kernel)
            continue;
        // The context's map where it built one (the engine builds them for wkb); a context made
        // without shadow maps (a tool, a test) gets the light's own map here instead.
        if (!sp.needsOwnShadowMap && ctx.lights[sp.lightIndex].shadowMap) {
            mMaps[i] = &*ctx.lights[sp.lightIndex].shadowMap;
            continue;
        }
        NbLight shadowLight = sp.light;
        if (!sp.directional) {  // a small area light: its shadows as seen from its centre
            shadowLight.type = NB_LIGHT_POINT;
        }
        mOwnMaps[i] = DeepShadowMap::build(shadowLight, ctx.volumes, dsm);
        mMaps[i] = &*mOwnMaps[i];
        if (sp.lightIndex >= 0 && size_t(sp.lightIndex) < stats.lights.size())
            stats.lights[sp.lightIndex].l2plusShadowMapBytes = mOwnMaps[i]->memoryBytes();
    }
    for (size_t v = 0; v < setup.volumes.size(); ++v) {
        const VolumeSetup& vs = setup.volumes[v];
        mPyramids[v].allocateLevel0(lightGridBricks(ctx.volumes.volumes()[v]->density, vs.factor), vs.channels);
        fillLevel0(ctx, setup, v);
    }
    stats.addStage("light volumes", secondsSince(t0));

    auto t1 = std::chrono::steady_clock::now();
    size_t total = 0;
    stats.volumes.resize(setup.volumes.size());
    for (size_t v = 0; v < setup.volumes.size(); ++v) {
        mPyramids[v].buildLevels(setup.volumes[v].maxSigma, LightPyramid::kMaxLevels, &ctx.stop);
        stats.volumes[v].mipLevels = mPyramids[v].levels();
        stats.volumes[v].pyramidBytes = mPyramids[v].memoryBytes();
        total += stats.volumes[v].pyramidBytes;
    }
    stats.pyramidBytes = total;
    stats.addStage("light pyramids", secondsSince(t1));
}

void LightVolumes::fillLevel0(const RenderContext& ctx, const WkbSetup& setup, size_t v)
{
    const VolumeData& vol = *ctx.volumes.volumes()[v];
    const VolumeSetup& vs = setup.volumes[v];
    LightPyramid& pyr = mPyramids[v];
    const int C = pyr.channels();
    const float f = float(vs.factor);
    const float rMin = 0.5f * vs.lightVoxel;
    const float shadowStep = ctx.scene->render.shadowStep * f;  // light rays at the light grid's scale
    const EmbreeScene* casters = ctx.shadowCasters();
    int maxShOrder = 0;
    for (const SourcePlan& sp : setup.sources)
        if (sp.mode == SourceMode::Sh && sp.kernel)
            maxShOrder = std::max(maxShOrder, sp.order);

    tbb::parallel_for(tbb::blocked_range<size_t>(0, pyr.level0BrickCount()), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<double> acc(static_cast<size_t>(C));
        std::vector<double> y(static_cast<size_t>(shCount(maxShOrder)));
        for (size_t bi = r.begin(); bi != r.end(); ++bi) {
            const Int3 b = pyr.level0Brick(bi);
            float* out = pyr.level0Values(bi);
            for (int z = 0; z < kS; ++z)
                for (int yy = 0; yy < kS; ++yy)
                    for (int x = 0; x < kS; ++x) {
                        // Per voxel (up to 128 shadow rays each), and inside the rays below.
                        throwIfStopped(&ctx.stop);
                        float* o = out + (size_t((z * kS + yy) * kS + x)) * C;
                        const int qi = b.x * BrickGrid::kBrick + x, qj = b.y * BrickGrid::kBrick + yy,
                                  qk = b.z * BrickGrid::kBrick + z;
                        const float3 centre = vs.origin + make_float3(qi * f, qj * f, qk * f);  // density index space
                        // Eight sub-samples at the centres of the voxel's octants.
                        float3 pos[8];
                        float rho[8];
                        double rhoSum = 0.0;
                        for (int s = 0; s < 8; ++s) {
                            pos[s] =
                                centre + make_float3(s & 1 ? 0.25f * f : -0.25f * f, s & 2 ? 0.25f * f : -0.25f * f,
                                                     s & 4 ? 0.25f * f : -0.25f * f);
                            rho[s] = std::max(0.0f, vol.density.sample(pos[s]));
                            rhoSum += rho[s];
                        }
                        std::fill(o, o + C, 0.0f);
                        const double rhoMean = rhoSum / 8.0;
                        if (!(rhoMean > 0.0))
                            continue;
                        o[0] = float(rhoMean);
                        if (!vs.l2plus)
                            continue;
                        std::fill(acc.begin(), acc.end(), 0.0);
                        const float3 wc = vol.worldFromIndex.point(centre);
                        const nb_uint voxelKey =
                            nb_uint(qi * 73856093) ^ nb_uint(qj * 19349663) ^ nb_uint(qk * 83492791);
                        for (size_t si = 0; si < setup.sources.size(); ++si) {
                            const SourcePlan& sp = setup.sources[si];
                            if (!sp.kernel)
                                continue;  // traced, not read from here (WkbPlanner)
                            if (sp.mode == SourceMode::Delta) {
                                for (int s = 0; s < 8; ++s) {
                                    if (rho[s] <= 0.0f)
                                        continue;
                                    Rgb E = deltaE(sp, si, vol.worldFromIndex.point(pos[s]), rMin);
                                    acc[sp.offset + 0] += rho[s] * E.x;
                                    acc[sp.offset + 1] += rho[s] * E.y;
                                    acc[sp.offset + 2] += rho[s] * E.z;
                                }
                                for (int c = 0; c < 3; ++c)
                                    acc[sp.offset + c] /= 8.0;
                            } else if (sp.mode == SourceMode::Sh) {
                                const EnvironmentMap* envMap =
                                    sp.lightIndex >= 0 ? ctx.lights[size_t(sp.lightIndex)].map.get() : nullptr;
                                NbRng rng = nbRngStart(0x5eedu + nb_uint(si), voxelKey, 0u);
                                const float r0 = nbRngNext(&rng), r1 = nbRngNext(&rng);
                                const int n = sp.emission ? kEmissionDirections : kShSamples;
                                const int count = shCount(sp.order);
                                for (int k = 0; k < n; ++k) {
                                    // Antithetic pairs: sample 2i+1 is sample 2i's opposite direction
                                    // (z -> -z, phi -> phi + pi for the sphere), so odd orders of an
                                    // even field integrate to exactly 0 instead of to sampling noise.
                                    const int i = k / 2;
                                    float u0 = fract((i + 0.5f) / (n / 2) + r0), u1 = fract(i * kGoldenFraction + r1);
                                    if (k & 1)
                                        u0 = 1.0f - u0, u1 = fract(u1 + 0.5f);
                                    Rgb L;
                                    float3 travel;  // the direction the light propagates, n'
                                    if (sp.emission) {
                                        float3 u = nbSampleSphereUniform(u0, u1);
                                        L = emittedRadiance(ctx.volumes, wc, u, shadowStep, casters, 0.0f,
                                                            &ctx.stop) *
                                            (4.0f * NB_PI);
                                        travel = -u;
                                    } else {
                                        NbLightSample ls = nbLightSample(sp.light, wc, u0, u1);
                                        if (envMap)  // an environment map: its texel scales the
                                            ls.weight = ls.weight * envMap->lookup(ls.wi);  // uniform sample
                                        if (nbMaxComponent(ls.weight) <= 0.0f)
                                            continue;
                                        if (casters &&
                                            casters->occluded(wc, ls.wi, 0.0f, std::min(ls.distance, 1e30f)))
                                            continue;  // a shadow caster between the voxel and the light
                                        Rgb tau = ctx.volumes.opticalDepth(
                                            wc, ls.wi, 0.0f, std::min(ls.distance, 1e30f), shadowStep, &ctx.stop);
                                        L = ls.weight * exp(-tau);  // L_i / pdf
                                        travel = -ls.wi;
                                    }
                                    if (nbMaxComponent(L) <= 0.0f)
                                        continue;
                                    shEvaluate(sp.order, travel, y.data());
                                    for (int jm = 0; jm < count; ++jm) {
                                        acc[sp.offset + 3 * jm + 0] += y[jm] * L.x / n;
                                        acc[sp.offset + 3 * jm + 1] += y[jm] * L.y / n;
                                        acc[sp.offset + 3 * jm + 2] += y[jm] * L.z / n;
                                    }
                                }
                                for (int c = 0; c < sp.channelCount; ++c)
                                    acc[sp.offset + c] *= rhoMean;
                            }
                        }
                        for (int c = 1; c < C; ++c)
                            o[c] = float(acc[c]);
                    }
        }
    });
}

}  // namespace nimbus::wkb
