#include "ScatterPoints.h"

#include "../render/StiffVoxels.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

namespace {

// The march's step, in multiples of the span's L1 step: a point only needs T b to the accuracy of
// a quadrature, and the weight is exact for the medium the march sees.
constexpr float kStepScale = 2.0f;
// A step is split into sub-steps of at most kSubStepDepth optical depth (StiffVoxels.h, as the
// camera march's stiff sub-steps), each with its own coefficients, at most kMaxSplit of them. A
// step's constant coefficients spread its points over the step as if the medium were uniform
// there; where a step is optically thick that misplaces them within the first mean free path
// (a voxelised surface: a one-voxel ramp of optical depth 12 put the points' L1 of a lit box at
// 3x the march's, tests/single/test_scatter_source.cpp), where the light they gather changes
// fastest.
constexpr int kMaxSplit = 64;

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

}  // namespace

bool ScatterPointSampler::march(const RenderContext& ctx, float3 o, float3 d, float tFar, NbRng& rng, float seconds,
                                float minTransmittance)
{
    const VolumeSet& vs = ctx.volumes;
    mSteps.clear();
    mTotal = 0.0;
    vs.spansAt(seconds, o, d, 0.0f, std::min(tFar, 1e30f), ctx.scene->render.step, mSpans);
    if (mSpans.empty())
        return false;
    const float jitter = nbRngNext(&rng);
    mJitter = jitter;
    // One still volume with stiff bricks (StiffVoxels.h): there a brick's densest voxel bounds a
    // step's optical depth, which a probe in the thin end of a ramp would miss.
    const StiffVoxels* stiff = ctx.stiff.size() == 1 && ctx.stiff[0].any && !ctx.moving() ? &ctx.stiff[0] : nullptr;
    const float stiffStep = stiff ? ctx.scene->render.step * vs.volumes()[0]->voxelSize : 1.0f;  // its camera step
    float T[3] = {1.0f, 1.0f, 1.0f};
    bool opaque = false;
    for (const Span& span : mSpans) {
        const float len = span.t1 - span.t0;
        if (!(len > 0.0f))
            continue;
        // Steps of kStepScale L1 steps, but never under half the smallest voxel: a finer L1 step
        // (render.step, down to denormals) buys L1's shadows, not a better T b here.
        const float target = std::max(kStepScale * span.step, 0.5f * vs.minVoxelSize());
        const int n = std::max(1, int(std::min(std::ceil(len / target), 1e7f)));
        const float dt = len / float(n);
        for (int k = 0; k < n && !opaque; ++k) {
            if (unsigned(k) % kStopPollInterval == kStopPollInterval - 1 && ctx.stop.raised())
                return false;
            const float t = span.t0 + float(k) * dt;
            const float3 probe = o + d * (t + jitter * dt);
            float share;
            BrickGrid::Stencil stencil;
            float3 lightPoint;
            MediumSample m = stiff ? vs.sampleAt(seconds, probe, &share, &stencil, &lightPoint)
                                   : vs.sampleAt(seconds, probe);
            float split = std::ceil(nbMaxComponent(fmax(m.sigma_t, m.sigma_s)) * dt / kSubStepDepth);
            if (stiff)  // subStepsOf: sub-steps of kSubStepDepth in a camera step of stiffStep
                split = std::max(split, std::ceil(float(stiff->subStepsOf(stencil.brick)) * dt / stiffStep));
            const int splits = int(std::clamp(split, 1.0f, float(kMaxSplit)));
            const float subDt = dt / float(splits);
            for (int j = 0; j < splits && !opaque; ++j) {
                const float tj = t + float(j) * subDt;
                if (splits > 1)
                    m = vs.sampleAt(seconds, o + d * (tj + jitter * subDt));
                if (!(nbMaxComponent(m.sigma_t) > 0.0f))
                    continue;  // no medium here: nothing to draw, nothing attenuated
                Step st;
                st.t = tj;
                st.dt = subDt;
                for (int c = 0; c < 3; ++c) {
                    st.T[c] = T[c];
                    st.b[c] = channel(m.sigma_s, c);
                    st.c[c] = std::max(channel(m.sigma_t, c), st.b[c]);
                }
                double w;
                if (st.c[1] == st.c[0] && st.c[2] == st.c[0] && T[1] == T[0] && T[2] == T[0]) {  // grey
                    const float decay = std::exp(-st.c[0] * subDt);
                    w = double(T[0]) * (double(st.b[0]) + st.b[1] + st.b[2]) * expIntegral(st.c[0], subDt);
                    T[0] *= decay, T[1] = T[2] = T[0];
                } else {
                    w = 0.0;
                    for (int c = 0; c < 3; ++c) {
                        w += double(T[c]) * st.b[c] * expIntegral(st.c[c], subDt);
                        T[c] *= std::exp(-st.c[c] * subDt);
                    }
                }
                if (w > 0.0) {
                    mTotal += w / 3.0;
                    st.cumulative = mTotal;
                    mSteps.push_back(st);
                }
                opaque = std::max(T[0], std::max(T[1], T[2])) < minTransmittance;
            }
        }
        if (opaque)
            break;
    }
    mEndT = make_float3(T[0], T[1], T[2]);
    // draw()'s density is largest at a step's start: its probability times the offset's density there.
    mMaxPdf = 0.0;
    double previous = 0.0;
    for (const Step& st : mSteps) {
        const double probability = (st.cumulative - previous) / mTotal;
        previous = st.cumulative;
        const float cMean = (st.c[0] + st.c[1] + st.c[2]) / 3.0f;
        const double offsetPdf = cMean * st.dt < 1e-4f ? 1.0 / st.dt : cMean / -std::expm1(-double(cMean) * st.dt);
        mMaxPdf = std::max(mMaxPdf, probability * offsetPdf);
    }
    return mTotal > 0.0;
}

ScatterPoint ScatterPointSampler::at(float3 o, float3 d, float t) const
{
    ScatterPoint p{};
    p.x = o + d * t;
    auto it = std::upper_bound(mSteps.begin(), mSteps.end(), t, [](float v, const Step& s) { return v < s.t; });
    if (it == mSteps.begin())
        return p;
    const Step& st = *(it - 1);
    const float u = t - st.t;
    if (!(u >= 0.0f && u <= st.dt))
        return p;
    const double prevCumulative = &st == &mSteps.front() ? 0.0 : (&st - 1)->cumulative;
    const double stepProbability = (st.cumulative - prevCumulative) / mTotal;
    const float cMean = (st.c[0] + st.c[1] + st.c[2]) / 3.0f;
    double offsetPdf;
    if (cMean * st.dt < 1e-4f)
        offsetPdf = 1.0 / st.dt;
    else
        offsetPdf = cMean * std::exp(-double(cMean) * u) / -std::expm1(-double(cMean) * st.dt);
    p.pdf = stepProbability * offsetPdf;
    for (int c = 0; c < 3; ++c) {
        p.T[c] = double(st.T[c]) * std::exp(-double(st.c[c]) * u);
        p.W[c] = p.T[c] * st.b[c];
        p.b[c] = st.b[c];
        p.c[c] = st.c[c];
    }
    return p;
}

ScatterPoint ScatterPointSampler::draw(float3 o, float3 d, int k, int K, NbRng& rng) const
{
    ScatterPoint p{};
    const double pick = (double(k) + double(nbRngNext(&rng))) / double(K) * mTotal;
    const auto it = std::lower_bound(mSteps.begin(), mSteps.end(), pick,
                                     [](const Step& s, double v) { return s.cumulative < v; });
    const Step& st = it == mSteps.end() ? mSteps.back() : *it;
    const double prevCumulative = &st == &mSteps.front() ? 0.0 : (&st - 1)->cumulative;
    const double stepProbability = (st.cumulative - prevCumulative) / mTotal;
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
    p.pdf = pdf;
    for (int c = 0; c < 3; ++c) {
        p.T[c] = double(st.T[c]) * std::exp(-double(st.c[c]) * u);
        p.W[c] = pdf > 0.0 ? p.T[c] * st.b[c] / pdf : 0.0;
        p.b[c] = st.b[c];
        p.c[c] = st.c[c];
    }
    p.x = o + d * (st.t + u);
    return p;
}

std::vector<NbPhase> PhaseMix::phasesOf(const RenderContext& ctx)
{
    std::vector<NbPhase> phases;
    for (auto& v : ctx.volumes.volumes())
        phases.push_back(v->medium.phase);
    return phases;
}

bool PhaseMix::at(const VolumeSet& vs, float3 x, float seconds)
{
    mWeights.assign(mPhases->size(), 0.0f);
    vs.sampleAt(seconds, x, mWeights.data());
    mTotal = 0.0f;
    for (float& w : mWeights) {
        w = std::max(w, 0.0f);
        mTotal += w;
    }
    if (mTotal > 0.0f)
        return true;
    mWeights[0] = 1.0f;  // a stand-in where the march's step saw medium and the point none
    mTotal = 1.0f;
    return false;
}

float PhaseMix::eval(float cosTheta) const
{
    float p = 0.0f;
    for (size_t v = 0; v < mPhases->size(); ++v)
        if (mWeights[v] > 0.0f)
            p += mWeights[v] * nbPhaseEval((*mPhases)[v], cosTheta);
    return p / mTotal;
}

float3 PhaseMix::sample(float3 axis, float u0, float u1, float u2) const
{
    float pick = u0 * mTotal;
    size_t v = 0;
    for (; v + 1 < mPhases->size(); ++v) {
        if (pick < mWeights[v])
            break;
        pick -= mWeights[v];
    }
    const float u = mWeights[v] > 0.0f ? std::min(pick / mWeights[v], 0.99999994f) : u0;
    return nbPhaseSample((*mPhases)[v], axis, u, u1, u2);
}

}  // namespace nimbus
