#include "EmissionScatter.h"

#include "../core/StepCount.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

Rgb emittedRadiance(const VolumeSet& vs, float3 x, float3 u, float stepFraction, const EmbreeScene* casters,
                    float seconds, const StopFlag* stop)
{
    thread_local std::vector<Span> spans;
    const float tMax = casters ? std::min(1e30f, casters->shadowHit(x, u, 0.0f, INFINITY)) : 1e30f;
    vs.spansAt(seconds, x, u, 0.0f, tMax, stepFraction, spans);
    Rgb L = splat(0.0f), T = splat(1.0f);
    unsigned polled = 0;
    for (const Span& s : spans) {
        float len = s.t1 - s.t0;
        int n = stepCount(len, s.step);
        float dt = len / float(n);
        for (int k = 0; k < n; ++k) {
            MediumSample m = vs.sampleAt(seconds, x + u * (s.t0 + (k + 0.5f) * dt));
            Rgb w = make_float3(m.sigma_t.x > 0 ? -std::expm1(-m.sigma_t.x * dt) / m.sigma_t.x : dt,
                                m.sigma_t.y > 0 ? -std::expm1(-m.sigma_t.y * dt) / m.sigma_t.y : dt,
                                m.sigma_t.z > 0 ? -std::expm1(-m.sigma_t.z * dt) / m.sigma_t.z : dt);
            L += T * w * m.emission;
            T = T * exp(-m.sigma_t * dt);
            if (nbMaxComponent(T) < 1e-4f || (++polled % kStopPollInterval == 0 && stopRaised(stop)))
                return L;
        }
    }
    return L;
}

EmissionScatter::EmissionScatter(const RenderContext& ctx)
    : mCtx(&ctx), mActive(ctx.volumes.hasEmission()), mSamples(std::max(1, ctx.scene->render.emissionSamples)),
      mPhases(PhaseMix::phasesOf(ctx))
{
}

void EmissionScatter::add(float3 o, float3 d, NbRng& rng, CameraSample& out, float tFar, float seconds) const
{
    if (!mActive)
        return;
    const RenderContext& ctx = *mCtx;
    thread_local ScatterPointSampler points;
    if (!points.march(ctx, o, d, tFar, rng, seconds))
        return;
    thread_local PhaseMix phase;
    phase.use(mPhases);
    const EmbreeScene* casters = ctx.shadowCasters();
    const float stepFraction = ctx.scene->render.step;
    Rgb sum = splat(0.0f);
    for (int k = 0; k < mSamples && !ctx.stop.raised(); ++k) {
        const ScatterPoint p = points.draw(o, d, k, mSamples, rng);
        phase.at(ctx.volumes, p.x, seconds);
        // w' by the phase function about d: p(w' . d) / pdf = 1.
        const float3 w = phase.sample(d, nbRngNext(&rng), nbRngNext(&rng), nbRngNext(&rng));
        const Rgb Le = emittedRadiance(ctx.volumes, p.x, w, stepFraction, casters, seconds, &ctx.stop);
        if (!std::isfinite(Le.x + Le.y + Le.z))
            continue;
        sum += make_float3(float(p.W[0] * Le.x), float(p.W[1] * Le.y), float(p.W[2] * Le.z));
    }
    out.L1 += sum * (1.0f / float(mSamples));
}

}  // namespace nimbus
