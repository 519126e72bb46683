#include "TracedOrder2.h"

#include "../single/ScatterPoints.h"
#include "../single/ScatterSource.h"

#include "../../kernels/shared/equiangular.h"

#include <algorithm>
#include <cmath>

namespace nimbus::wkb {

namespace {
// Points drawn (stratified) along each secondary direction: the march along it costs more than
// reading the source at a point, so a second point halves the t integral's variance for little.
constexpr int kPointsAlong = 2;
}  // namespace

TracedOrder2::TracedOrder2(const RenderContext& ctx)
    : mCtx(&ctx), mSamples(std::max(1, ctx.scene->render.wkbOrder2Samples)), mPhases(PhaseMix::phasesOf(ctx))
{
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        const LightEntry& e = ctx.lights[i];
        if (e.used && e.light.type != NB_LIGHT_ENVIRONMENT)
            mLobeLights.push_back(int(i));
        if (e.used && (e.light.type == NB_LIGHT_POINT || e.light.type == NB_LIGHT_SPOT))
            mPointLights.push_back(int(i));
    }
}

const ScatterPointSampler* TracedOrder2::add(float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight,
                                             float tFar, float seconds) const
{
    const RenderContext& ctx = *mCtx;
    thread_local ScatterPointSampler points;
    if (!points.march(ctx, o, d, tFar, rng, seconds))
        return nullptr;
    thread_local PhaseMix phase;
    phase.use(mPhases);
    for (int k = 0; k < mSamples && !ctx.stop.raised(); ++k)
        sample(points.draw(o, d, k, mSamples, rng), d, phase, rng, out, perLight, seconds);
    return &points;
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

    // L1 arriving at x from w' (the integral of T b S along x + t w', ScatterSource.h): points y
    // of that ray drawn by T b, and single scattering's source there toward x. The ray stops at a
    // shadow caster, which also hides the sky behind it.
    float tSecondary = INFINITY;
    if (const EmbreeScene* casters = ctx.shadowCasters())
        tSecondary = casters->shadowHit(x, w, 0.0f, INFINITY);
    thread_local ScatterPointSampler along;
    // Stopped at render.tolerance, as single's march along it was.
    if (!along.march(ctx, x, w, tSecondary, rng, seconds, ctx.scene->render.tolerance))
        return;
    const Rgb Tend = along.transmittance();
    const bool tail = !(tSecondary < INFINITY) && nbMaxComponent(Tend) >= ctx.scene->render.tolerance;
    const size_t stride = 3 * ctx.lights.size();
    const int K = kPointsAlong;
    // The point and spot lights near this ray, each with its equi-angular distribution over the
    // march's extent (equiangular.h's test: its peak density at least NB_EQUI_MIN_PEAK times the
    // T b draws' largest).
    thread_local std::vector<std::pair<int, NbEquiAngular>> equi;
    equi.clear();
    const float ta = along.begin(), tb = along.end();
    for (int li : mPointLights) {
        const float3 c = nbLoad3(ctx.lights[size_t(li)].light.position);
        if (nbEquiPeakBound(x, w, c, ta, tb) < NB_EQUI_MIN_PEAK * float(along.maxPdf()))
            continue;
        const NbEquiAngular e = nbEquiInit(x, w, c, ta, tb);
        if (nbEquiWorthwhile(e, float(along.maxPdf())))
            equi.emplace_back(li, e);
    }
    // Adds the point's share: S (its per-light parts in secondaryPerLight) times scale, with the
    // parts of the lights in `equi` weighted by the balance heuristic, K pTb / (K pTb + pEqui) for
    // a T b draw, or (onlyLight >= 0, an equi-angular draw toward that light) only that light's
    // part, with pEqui / (K pTb + pEqui).
    auto gather = [&](const ScatterPoint& y, const double scale[3], int onlyLight, double equiPdf) {
        for (const auto& [li, e] : equi) {
            if (onlyLight >= 0 && li != onlyLight)
                continue;
            const double pe = onlyLight >= 0 ? equiPdf : double(nbEquiPdf(e, dot(y.x - x, w)));
            const double weight = onlyLight >= 0 ? pe / (K * y.pdf + pe) : K * y.pdf / (K * y.pdf + pe);
            for (int c = 0; c < 3; ++c)
                secondaryPerLight[size_t(3 * li + c)] *= float(weight);
        }
        Rgb S = splat(0.0f);
        for (size_t i = 0; i < ctx.lights.size(); ++i) {
            float* part = &secondaryPerLight[3 * i];
            if (onlyLight >= 0 && int(i) != onlyLight)
                part[0] = part[1] = part[2] = 0.0f;
            S += make_float3(part[0], part[1], part[2]);
        }
        if (!std::isfinite(S.x + S.y + S.z))
            return;
        out.L2plus += make_float3(float(scale[0] * S.x), float(scale[1] * S.y), float(scale[2] * S.z));
        if (perLight)
            for (size_t i = 0; i < stride; ++i)
                perLight[i] += float(scale[i % 3] * secondaryPerLight[i]);
    };
    for (int k = 0; k < K; ++k) {
        const ScatterPoint y = along.draw(x, w, k, K, rng);
        // T(y, end), the sky tail's share; none where a caster hides the sky or, as single's
        // march has it, where the ray's transmittance falls under render.tolerance.
        Rgb behind = splat(0.0f);
        if (tail)
            behind = make_float3(y.T[0] > 0.0 ? float(Tend.x / y.T[0]) : 0.0f,
                                 y.T[1] > 0.0 ? float(Tend.y / y.T[1]) : 0.0f,
                                 y.T[2] > 0.0 ? float(Tend.z / y.T[2]) : 0.0f);
        secondaryPerLight.assign(stride, 0.0f);
        singleScatterSource(ctx, y.x, w, behind, rng, secondaryPerLight.data(), seconds);
        double scale[3];
        for (int c = 0; c < 3; ++c)
            scale[c] = p.W[c] * dirWeight * y.W[c] / (double(mSamples) * K);
        gather(y, scale, -1, 0.0);
    }
    for (const auto& [li, e] : equi) {
        const float t = nbEquiSample(e, nbRngNext(&rng));
        const double pe = double(nbEquiPdf(e, t));
        const ScatterPoint y = along.at(x, w, t);
        if (!(pe > 0.0) || !(y.pdf > 0.0))
            continue;  // no medium there (a gap, or past where the march stopped): T b is 0
        secondaryPerLight.assign(stride, 0.0f);
        singleScatterSource(ctx, y.x, w, splat(0.0f), rng, secondaryPerLight.data(), seconds);  // no sky: its tail unused
        double scale[3];
        for (int c = 0; c < 3; ++c)
            scale[c] = p.W[c] * dirWeight * y.W[c] / (double(mSamples) * pe);
        gather(y, scale, li, pe);
    }
}

}  // namespace nimbus::wkb
