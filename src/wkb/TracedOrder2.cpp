#include "TracedOrder2.h"

#include "../single/SingleScatter.h"

#include <algorithm>
#include <cmath>

namespace nimbus::wkb {

namespace {

// The sampling march's step, in multiples of the span's L1 step: the point only needs T b to the
// accuracy of a quadrature, and the weight below is exact for the medium the march sees.
constexpr float kStepScale = 2.0f;
// The march stops where every channel's transmittance is under this: what lies beyond can add at
// most this fraction of the ray's order 2.
constexpr float kMinTransmittance = 1e-4f;

// One step of the sampling march: [t, t + dt] with constant coefficients.
struct Step {
    float t, dt;
    float T[3];  // transmittance from the camera to t
    float b[3], c[3];
    double cumulative;  // sum of the steps' weights up to and including this one
};

float channel(Rgb v, int c)
{
    return c == 0 ? v.x : (c == 1 ? v.y : v.z);
}

// int_0^dt e^{-c u} du, without 0/0 at c dt -> 0.
float expIntegral(float c, float dt)
{
    const float x = c * dt;
    return x < 1e-4f ? dt * (1.0f - 0.5f * x) : -std::expm1(-x) / c;
}

// The phase function of the medium mixture at a point: volumes weighted by their share of b.
struct PhaseMix {
    const std::vector<NbPhase>* phases;
    const float* weights;
    float total;

    float eval(float cosTheta) const
    {
        float p = 0.0f;
        for (size_t v = 0; v < phases->size(); ++v)
            if (weights[v] > 0.0f)
                p += weights[v] * nbPhaseEval((*phases)[v], cosTheta);
        return p / total;
    }
    // A direction whose cosine with `axis` follows the mixture (u0 picks the volume, then is reused).
    float3 sample(float3 axis, float u0, float u1, float u2) const
    {
        float pick = u0 * total;
        size_t v = 0;
        for (; v + 1 < phases->size(); ++v) {
            if (pick < weights[v])
                break;
            pick -= weights[v];
        }
        const float u = weights[v] > 0.0f ? std::min(pick / weights[v], 0.99999994f) : u0;
        return nbPhaseSample((*phases)[v], axis, u, u1, u2);
    }
};

thread_local std::vector<Step> tlSteps;  // the sampling march of the current camera ray

}  // namespace

TracedOrder2::TracedOrder2(const RenderContext& ctx) : mCtx(&ctx), mSamples(std::max(1, ctx.scene->render.wkbOrder2Samples))
{
    for (auto& v : ctx.volumes.volumes())
        mPhase.push_back(v->medium.phase);
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        const LightEntry& e = ctx.lights[i];
        if (e.used && e.light.type != NB_LIGHT_ENVIRONMENT)
            mLobeLights.push_back(int(i));
    }
}

void TracedOrder2::add(float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight, float tFar) const
{
    const RenderContext& ctx = *mCtx;
    const VolumeSet& vs = ctx.volumes;
    thread_local std::vector<Span> spans;
    std::vector<Step>& steps = tlSteps;
    vs.spans(o, d, 0.0f, std::min(tFar, 1e30f), ctx.scene->render.step, spans);
    if (spans.empty())
        return;

    // 1. The march: T b integrated exactly over each step of constant coefficients.
    steps.clear();
    const float jitter = nbRngNext(&rng);
    float T[3] = {1.0f, 1.0f, 1.0f};
    double total = 0.0;
    bool opaque = false;
    for (const Span& span : spans) {
        const float len = span.t1 - span.t0;
        if (!(len > 0.0f))
            continue;
        // Steps of kStepScale L1 steps, but never under half a voxel (span.step / render.step): a
        // finer L1 step (render.step) buys L1's shadows, not a better T b here.
        const float voxel = span.step / std::max(ctx.scene->render.step, 1e-30f);
        const float target = std::max(kStepScale * span.step, 0.5f * voxel);
        const int n = std::max(1, int(std::min(std::ceil(len / target), 1e7f)));
        const float dt = len / float(n);
        for (int k = 0; k < n && !opaque; ++k) {
            if (unsigned(k) % kStopPollInterval == kStopPollInterval - 1 && ctx.stop.raised())
                return;
            const float t = span.t0 + float(k) * dt;
            const MediumSample m = vs.sample(o + d * (t + jitter * dt));
            Step st;
            st.t = t;
            st.dt = dt;
            double w = 0.0;
            for (int c = 0; c < 3; ++c) {
                st.T[c] = T[c];
                st.b[c] = channel(m.sigma_s, c);
                st.c[c] = std::max(channel(m.sigma_t, c), st.b[c]);
                w += double(T[c]) * st.b[c] * expIntegral(st.c[c], dt);
                T[c] *= std::exp(-st.c[c] * dt);
            }
            if (w > 0.0) {
                total += w / 3.0;
                st.cumulative = total;
                steps.push_back(st);
            }
            opaque = std::max(T[0], std::max(T[1], T[2])) < kMinTransmittance;
        }
        if (opaque)
            break;
    }
    if (!(total > 0.0))
        return;

    for (int k = 0; k < mSamples && !ctx.stop.raised(); ++k)
        sample(o, d, rng, total, k, out, perLight);
}

void TracedOrder2::sample(float3 o, float3 d, NbRng& rng, double total, int k, CameraSample& out,
                          float* perLight) const
{
    const double scaleAll = 1.0 / mSamples;
    const RenderContext& ctx = *mCtx;
    const VolumeSet& vs = ctx.volumes;
    const std::vector<Step>& steps = tlSteps;
    thread_local std::vector<float> phaseWeights, secondaryPerLight;
    // 2. The scattering point: a step by its weight (stratified over the ray's samples), then the offset in it by e^{-c u} (c the
    // channels' mean), and each channel's weight T_c(s) b_c / pdf(s).
    const double pick = (double(k) + double(nbRngNext(&rng))) * scaleAll * total;
    const auto it = std::lower_bound(steps.begin(), steps.end(), pick,
                                     [](const Step& s, double v) { return s.cumulative < v; });
    const Step& st = it == steps.end() ? steps.back() : *it;
    const double prevCumulative = &st == &steps.front() ? 0.0 : (&st - 1)->cumulative;
    const double stepProbability = (st.cumulative - prevCumulative) / total;
    const float cMean = (st.c[0] + st.c[1] + st.c[2]) / 3.0f;
    const float uStep = nbRngNext(&rng);
    float u, offsetPdf;
    if (cMean * st.dt < 1e-4f) {
        u = uStep * st.dt;
        offsetPdf = 1.0f / st.dt;
    } else {
        const float mass = -std::expm1(-cMean * st.dt);
        u = std::min(-std::log1p(-uStep * mass) / cMean, st.dt);
        offsetPdf = cMean * std::exp(-cMean * u) / mass;
    }
    const double pdf = stepProbability * double(offsetPdf);
    if (!(pdf > 0.0))
        return;
    double W[3];
    for (int c = 0; c < 3; ++c)
        W[c] = double(st.T[c]) * std::exp(-double(st.c[c]) * u) * st.b[c] / pdf;
    const float3 x = o + d * (st.t + u);

    // 3. The direction w': one-sample MIS over the phase lobe about d and a lobe about the
    // direction toward each light, all shaped by the phase function at x.
    phaseWeights.assign(vs.volumes().size(), 0.0f);
    vs.sample(x, phaseWeights.data());
    float wsum = 0.0f;
    for (float w : phaseWeights)
        wsum += std::max(w, 0.0f);
    if (!(wsum > 0.0f)) {  // the step's sample saw medium, the point none: an isotropic stand-in
        phaseWeights.assign(phaseWeights.size(), 0.0f);
        phaseWeights[0] = 1.0f;
        wsum = 1.0f;
    }
    const PhaseMix phase{&mPhase, phaseWeights.data(), wsum};
    thread_local std::vector<float3> axes;
    axes.clear();
    axes.push_back(d);
    for (int li : mLobeLights) {
        const NbLight& l = ctx.lights[size_t(li)].light;
        float3 toLight;
        if (l.type == NB_LIGHT_DISTANT)
            toLight = -nbLoad3(l.direction);
        else
            toLight = nbLoad3(l.position) - x;
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

    // 4. L1 arriving at x from w': single's march along x + t w', stopped at a shadow caster.
    float tSecondary = INFINITY;
    if (const EmbreeScene* casters = ctx.shadowCasters())
        tSecondary = casters->shadowHit(x, w, 0.0f, INFINITY);
    const size_t stride = 3 * ctx.lights.size();
    secondaryPerLight.assign(stride, 0.0f);
    CameraSample secondary;
    marchSingle(ctx, x, w, rng, secondary, secondaryPerLight.data(), tSecondary);
    const Rgb L1 = secondary.L1;
    if (!std::isfinite(L1.x + L1.y + L1.z))
        return;
    double scale[3];
    for (int c = 0; c < 3; ++c)
        scale[c] = W[c] * dirWeight * scaleAll;
    out.L2plus += make_float3(float(scale[0] * L1.x), float(scale[1] * L1.y), float(scale[2] * L1.z));
    if (perLight)
        for (size_t i = 0; i < stride; ++i)
            perLight[i] += float(scale[i % 3] * secondaryPerLight[i]);
}

}  // namespace nimbus::wkb
