#include "SkyTail.h"

#include "../geometry/EmbreeScene.h"

#include <cmath>
#include <vector>

namespace nimbus {

bool skyBehindOpen(const RenderContext& ctx, float3 o, float3 d, bool heldOut)
{
    if (heldOut)
        return false;
    const EmbreeScene* casters = ctx.shadowCasters();
    if (!casters)
        return true;
    float tIn, tOut;
    if (!ctx.volumes.worldBounds().intersect(o, safeInverse(d), 0.0f, INFINITY, tIn, tOut))
        return true;
    return !casters->occluded(o, d, tIn, INFINITY);
}

void addSkyTails(const RenderContext& ctx, float3 d, Rgb T, const Rgb* tauS, size_t nVolumes, CameraSample& out,
                 float* perLight)
{
    if (!(nbMaxComponent(T) > 0.0f))
        return;
    size_t slot = 0;
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        const LightEntry& e = ctx.lights[i];
        if (!e.used || !e.sky)
            continue;
        Rgb c = splat(0.0f);
        for (size_t v = 0; v < nVolumes; ++v)
            c += e.sky->tailAlong(v, d) * tauS[slot * nVolumes + v];
        ++slot;
        c = c * T;
        out.L1 += c;
        perLight[3 * i + 0] += c.x, perLight[3 * i + 1] += c.y, perLight[3 * i + 2] += c.z;
    }
}

void addSkyTailsOneVolume(const RenderContext& ctx, const VolumeData& vol, float3 o, float3 d, Rgb T, bool heldOut,
                          CameraSample& out, float* perLight)
{
    if (!(nbMaxComponent(T) > 0.0f) || !skyBehindOpen(ctx, o, d, heldOut))
        return;
    const Rgb kS = vol.sigmaS(), kT = vol.sigmaT();
    auto tau = [](float s, float t, float tr) { return t > 0.0f && tr > 0.0f ? s / t * -std::log(tr) : 0.0f; };
    const Rgb tauS = make_float3(tau(kS.x, kT.x, T.x), tau(kS.y, kT.y, T.y), tau(kS.z, kT.z, T.z));
    thread_local std::vector<Rgb> perSky;
    perSky.clear();
    for (const LightEntry& e : ctx.lights)
        if (e.used && e.sky)
            perSky.push_back(tauS);
    addSkyTails(ctx, d, T, perSky.data(), 1, out, perLight);
}

}  // namespace nimbus
