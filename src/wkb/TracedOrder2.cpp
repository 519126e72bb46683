#include "TracedOrder2.h"

#include "../single/ScatterPoints.h"
#include "../single/SingleScatter.h"

#include <algorithm>
#include <cmath>

namespace nimbus::wkb {

TracedOrder2::TracedOrder2(const RenderContext& ctx)
    : mCtx(&ctx), mSamples(std::max(1, ctx.scene->render.wkbOrder2Samples)), mPhases(PhaseMix::phasesOf(ctx))
{
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        const LightEntry& e = ctx.lights[i];
        if (e.used && e.light.type != NB_LIGHT_ENVIRONMENT)
            mLobeLights.push_back(int(i));
    }
}

void TracedOrder2::add(float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight, float tFar,
                       float seconds) const
{
    const RenderContext& ctx = *mCtx;
    thread_local ScatterPointSampler points;
    if (!points.march(ctx, o, d, tFar, rng, seconds))
        return;
    thread_local PhaseMix phase;
    phase.use(mPhases);
    for (int k = 0; k < mSamples && !ctx.stop.raised(); ++k)
        sample(points.draw(o, d, k, mSamples, rng), d, phase, rng, out, perLight, seconds);
}

void TracedOrder2::sample(const ScatterPoint& p, float3 d, PhaseMix& phase, NbRng& rng, CameraSample& out,
                          float* perLight, float seconds) const
{
    const RenderContext& ctx = *mCtx;
    thread_local std::vector<float> secondaryPerLight;
    thread_local std::vector<float3> axes;
    const float3 x = p.x;

    // The direction w': one-sample MIS over the phase lobe about d and a lobe about the direction
    // toward each light, all shaped by the phase function at x.
    phase.at(ctx.volumes, x, seconds);
    axes.clear();
    axes.push_back(d);
    for (int li : mLobeLights) {
        const NbLight& l = ctx.lights[size_t(li)].light;
        const float3 toLight = l.type == NB_LIGHT_DISTANT ? -nbLoad3(l.direction) : nbLoad3(l.position) - x;
        const float len = length(toLight);
        if (len > 0.0f)
            axes.push_back(toLight * (1.0f / len));
    }
    const float uStrategy = nbRngNext(&rng);
    const size_t strategy = std::min(axes.size() - 1, size_t(uStrategy * float(axes.size())));
    const float3 w = phase.sample(axes[strategy], nbRngNext(&rng), nbRngNext(&rng), nbRngNext(&rng));
    double dirPdf = 0.0;
    for (const float3& a : axes)
        dirPdf += double(phase.eval(dot(w, a)));
    dirPdf /= double(axes.size());
    const double f = double(phase.eval(dot(w, d)));
    if (!(dirPdf > 0.0) || !(f > 0.0))
        return;
    const double dirWeight = f / dirPdf;

    // L1 arriving at x from w': single's march along x + t w', stopped at a shadow caster.
    float tSecondary = INFINITY;
    if (const EmbreeScene* casters = ctx.shadowCasters())
        tSecondary = casters->shadowHit(x, w, 0.0f, INFINITY);
    const size_t stride = 3 * ctx.lights.size();
    secondaryPerLight.assign(stride, 0.0f);
    CameraSample secondary;
    marchSingle(ctx, x, w, rng, secondary, secondaryPerLight.data(), tSecondary, seconds);
    const Rgb L1 = secondary.L1;
    if (!std::isfinite(L1.x + L1.y + L1.z))
        return;
    double scale[3];
    for (int c = 0; c < 3; ++c)
        scale[c] = p.W[c] * dirWeight / mSamples;
    out.L2plus += make_float3(float(scale[0] * L1.x), float(scale[1] * L1.y), float(scale[2] * L1.z));
    if (perLight)
        for (size_t i = 0; i < stride; ++i)
            perLight[i] += float(scale[i % 3] * secondaryPerLight[i]);
}

}  // namespace nimbus::wkb
