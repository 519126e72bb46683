#include "SingleScatter.h"

#include <cmath>
#include <vector>

namespace nimbus {

namespace {

// The integral over a step of length dt of exp(-sigma_t s) ds, per channel:
// (1 - e^{-sigma_t dt}) / sigma_t, written with expm1 so that thin steps keep their precision
// and stiff ones (sigma_t dt ~ 1e4) give 1/sigma_t without overflow.
inline float stepWeight(float sigma, float dt)
{
    return sigma > 0.0f ? -std::expm1(-sigma * dt) / sigma : dt;
}

// Below this transmittance in every channel the rest of the ray cannot change a pixel by more
// than ~1e-6 of the light already gathered; stop marching.
constexpr float kMinTransmittance = 1e-6f;

}  // namespace

void marchSingle(const RenderContext& ctx, float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight)
{
    const Scene& scene = *ctx.scene;
    const VolumeSet& vs = ctx.volumes;
    const size_t nVolumes = vs.volumes().size();
    const size_t nLights = ctx.lights.size();
    thread_local std::vector<Span> spanList;
    thread_local std::vector<float> phaseWeights;
    phaseWeights.resize(nVolumes);

    vs.spans(o, d, 0.0f, 1e30f, scene.render.step, spanList);
    const float jitter = nbRngNext(&rng);
    const int lightSamples = std::max(1, scene.render.lightSamples);
    Rgb T = splat(1.0f);
    float depthSum = 0.0f;

    for (const Span& span : spanList) {
        float len = span.t1 - span.t0;
        int n = std::max(1, int(std::ceil(len / span.step)));
        float dt = len / float(n);
        for (int k = 0; k < n; ++k) {
            float t = span.t0 + (k + jitter) * dt;
            float3 p = o + d * t;
            MediumSample m = vs.sample(p, phaseWeights.data());
            if (nbMaxComponent(m.sigma_t) <= 0.0f && nbMaxComponent(m.emission) <= 0.0f)
                continue;
            Rgb w = make_float3(stepWeight(m.sigma_t.x, dt), stepWeight(m.sigma_t.y, dt), stepWeight(m.sigma_t.z, dt));
            Rgb Tw = T * w;  // int over the step of T(0, s) ds
            out.L0 += Tw * m.emission;
            if (nbMaxComponent(m.sigma_s) > 0.0f) {
                float weightSum = 0.0f;
                for (size_t v = 0; v < nVolumes; ++v)
                    weightSum += phaseWeights[v];
                for (size_t i = 0; i < nLights; ++i) {
                    if (!ctx.lights[i].used)
                        continue;
                    const bool delta = ctx.lights[i].delta;
                    const int ns = delta ? 1 : lightSamples;
                    Rgb sum = splat(0.0f);
                    for (int s = 0; s < ns; ++s) {
                        float u0 = delta ? 0.5f : nbRngNext(&rng), u1 = delta ? 0.5f : nbRngNext(&rng);
                        float3 wi;
                        Rgb Li = ctx.incident(i, p, u0, u1, wi);
                        if (nbMaxComponent(Li) <= 0.0f)
                            continue;
                        // Light travels along -wi, then scatters into d (Tessendorf eq. 31).
                        float cosTheta = dot(-wi, d);
                        float phase = 0.0f;
                        for (size_t v = 0; v < nVolumes; ++v)
                            if (phaseWeights[v] > 0.0f)
                                phase += phaseWeights[v] * nbPhaseEval(vs.volumes()[v]->medium.phase, cosTheta);
                        phase /= std::max(weightSum, 1e-30f);
                        sum += Li * phase;
                    }
                    Rgb contribution = Tw * m.sigma_s * sum / float(ns);
                    out.L1 += contribution;
                    perLight[3 * i + 0] += contribution.x;
                    perLight[3 * i + 1] += contribution.y;
                    perLight[3 * i + 2] += contribution.z;
                }
            }
            float before = nbAverage(T);
            T = T * exp(-m.sigma_t * dt);
            depthSum += (before - nbAverage(T)) * t;
            if (nbMaxComponent(T) < kMinTransmittance) {
                T = splat(0.0f);
                break;
            }
        }
        if (nbMaxComponent(T) <= 0.0f)
            break;
    }
    out.L0 += T * ctx.background;
    out.transmittance = T;
    float alpha = 1.0f - nbAverage(T);
    out.depth = alpha > 0.0f ? depthSum / alpha : 0.0f;
}

}  // namespace nimbus
