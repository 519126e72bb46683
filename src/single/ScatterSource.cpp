#include "ScatterSource.h"

#include "../render/StiffVoxels.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace nimbus {

Rgb singleScatterSource(const RenderContext& ctx, float3 x, float3 d, Rgb behind, NbRng& rng, float* perLight,
                        float seconds)
{
    const VolumeSet& vs = ctx.volumes;
    const auto& volumes = vs.volumes();
    const size_t nVolumes = volumes.size();
    thread_local std::vector<float> phaseWeights;
    thread_local std::vector<BrickGrid::Stencil> stencils;
    phaseWeights.assign(nVolumes, 0.0f);
    stencils.resize(nVolumes);
    float3 lp;  // where the light maps are read (moving volumes: VolumeSet::sampleAt)
    vs.sampleAt(seconds, x, phaseWeights.data(), stencils.data(), &lp);
    float weightSum = 0.0f;
    for (float& w : phaseWeights)
        weightSum += (w = std::max(w, 0.0f));
    if (!(weightSum > 0.0f))
        return splat(0.0f);
    const float invWeightSum = 1.0f / weightSum;
    // A stiff brick: the baked lattice errs there, and the marches march each light's optical
    // depth back from the point itself (StiffVoxels.h).
    const VolumeData* stiff = nVolumes == 1 && !ctx.moving() && ctx.stiff[0].subStepsOf(stencils[0].brick) > 0
                                  ? volumes[0].get()
                                  : nullptr;
    const bool tail = nbMaxComponent(behind) > 0.0f;
    Rgb total = splat(0.0f);
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        const LightEntry& e = ctx.lights[i];
        if (!e.used)
            continue;
        Rgb c = splat(0.0f);
        if (e.sky) {
            float a[SkyLight::kCountMax];
            for (size_t v = 0; v < nVolumes; ++v) {
                if (!(phaseWeights[v] > 0.0f))
                    continue;
                e.sky->contraction(volumes[v]->medium.phase, -d, a);  // light leaves toward the viewer, along -d
                SkyLight::Cursor cursor;
                Rgb s = e.sky->radiance(v, volumes[v]->indexFromWorld.point(lp), a, cursor);
                if (tail)
                    s += e.sky->tailAlong(v, d) * behind;
                c += s * phaseWeights[v];
            }
            c = c * invWeightSum;
        } else {
            float3 wi;
            Rgb Li;
            if (e.cache) {
                Li = ctx.deltaWeight(i, x, wi, seconds);
                if (stiff) {
                    const float distance =
                        e.light.type == NB_LIGHT_DISTANT ? 1e30f : length(nbLoad3(e.light.position) - x);
                    Li = Li * exp(-stiffOpticalDepth(*stiff, e.cache->grid(0), stiff->indexFromWorld.point(x),
                                                     stiff->indexFromWorld.vector(wi), distance));
                } else {
                    Li = Li * e.cache->transmittance(stencils.data());
                }
            } else {
                const float u0 = e.delta ? 0.5f : nbRngNext(&rng), u1 = e.delta ? 0.5f : nbRngNext(&rng);
                Li = ctx.incident(i, x, u0, u1, wi, nullptr, seconds, &lp);
            }
            if (!(nbMaxComponent(Li) > 0.0f))
                continue;
            // Light travels along -wi, then toward the viewer along -d.
            const float cosTheta = dot(wi, d);
            float phase = 0.0f;
            for (size_t v = 0; v < nVolumes; ++v)
                if (phaseWeights[v] > 0.0f)
                    phase += phaseWeights[v] * nbPhaseEval(volumes[v]->medium.phase, cosTheta);
            c = Li * (phase * invWeightSum);
        }
        total += c;
        perLight[3 * i + 0] += c.x, perLight[3 * i + 1] += c.y, perLight[3 * i + 2] += c.z;
    }
    return total;
}

}  // namespace nimbus
