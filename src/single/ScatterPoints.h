// ScatterPoints.h: points of a camera ray drawn with probability proportional to T(0,s) b(s), the
// density of the last scattering before the camera (Tessendorf eq. 26 with a scattered source),
// and the phase function of the medium mixture there. Shared by the terms that gather light at
// such points: emission's L1 (EmissionScatter.h) and wkb's traced order 2 (wkb/TracedOrder2.h).
//
// march() walks the ray's spans in steps of constant coefficients (twice the L1 step, at least
// half a voxel, split where a step is thicker than half an optical depth), integrating T b exactly
// in each, until the transmittance is under 1e-4, and keeps the table; draw() then picks a step by
// its weight (stratified over the ray's K draws) and the offset inside it by e^{-c u} (c the
// channels' mean), and returns each channel's weight T_c(s) b_c / pdf(s). The estimate of
// int T b f ds by W f(x) is unbiased for the march's piecewise-constant medium.
#pragma once

#include "../render/RenderContext.h"

#include "../../kernels/shared/phase.h"
#include "../../kernels/shared/rng.h"

#include <vector>

namespace nimbus {

struct ScatterPoint {
    float3 x;
    double W[3];         // T_c(s) b_c(s) / pdf(s), 1 (dimensionless weight of the gathered radiance)
    double T[3];         // T_c(s), the transmittance from the ray's origin to x
    double b[3], c[3];   // the medium there, 1/m
    double pdf = 0.0;    // draw()'s density of this point's ray parameter, 1/m (over all K draws)
};

class ScatterPointSampler {
public:
    // The march stops where every channel's transmittance is under this by default: what lies
    // beyond can add at most this fraction of what is gathered (tighter than render.tolerance, the
    // camera march's: the points of emission's L1 deep in a medium are then within 1e-4 of
    // omega S / c, EmissionScatter.DeepInsideAMediumIsOmegaSOverC).
    static constexpr float kMinTransmittance = 1e-4f;

    // Marches o + s d (d unit), s in [0, tFar), until the transmittance is under minTransmittance
    // in every channel; false if the ray meets no scattering medium or the render was stopped.
    // Draws one number from rng.
    // seconds: the ray's shutter time, at which moving volumes are read (VolumeSet::sampleAt).
    bool march(const RenderContext& ctx, float3 o, float3 d, float tFar, NbRng& rng, float seconds = 0.0f,
               float minTransmittance = kMinTransmittance);
    // Draw k of K (stratified), after a successful march.
    ScatterPoint draw(float3 o, float3 d, int k, int K, NbRng& rng) const;
    // The transmittance from o to where the march ended (the ray's end, tFar, or under the cut-off in
    // every channel, where it stopped).
    Rgb transmittance() const { return mEndT; }
    // The ray parameters the march's steps cover, [begin, end] (after a successful march), and the
    // largest density draw() has over them (1/m).
    float begin() const { return mSteps.front().t; }
    float end() const { return mSteps.back().t + mSteps.back().dt; }
    double maxPdf() const { return mMaxPdf; }
    // The point at ray parameter t as draw() would return it there, its W the unweighted T_c b_c
    // (1/m; the caller divides by its own density) and its pdf draw()'s density at t (0 where no
    // step of the march holds t: no medium, or past where the march stopped). Another technique
    // combined with draw() by multiple importance sampling reads the medium and draw()'s density
    // at its own points here.
    ScatterPoint at(float3 o, float3 d, float t) const;
    // The march's table, after a successful march, for a term that integrates its own source over
    // the same steps (wkb's orders-3+ read, RadianceGrid.h readOrders3): f(t, dt, x, T, b, c) per
    // step with T b > 0, in order: the step [t, t + dt), the point x where the medium was read,
    // the transmittance T[3] from o to t, and the step's b[3] and c[3] (1/m). o and d as marched.
    template <class F>
    void forEachStep(float3 o, float3 d, F&& f) const
    {
        for (const Step& st : mSteps)
            f(st.t, st.dt, o + d * (st.t + mJitter * st.dt), st.T, st.b, st.c);
    }

private:
    struct Step {
        float t, dt;
        float T[3];  // transmittance from the camera to t
        float b[3], c[3];
        double cumulative;  // sum of the steps' weights up to and including this one
    };
    std::vector<Step> mSteps;
    std::vector<Span> mSpans;
    double mTotal = 0.0;
    double mMaxPdf = 0.0;
    float mJitter = 0.0f;  // each step's probe at t + mJitter dt
    Rgb mEndT = make_float3(1.0f, 1.0f, 1.0f);
};

// The phase function of the medium mixture at a point: the volumes weighted by their share of b.
class PhaseMix {
public:
    // The volumes' phase functions, index-aligned with ctx.volumes.volumes().
    static std::vector<NbPhase> phasesOf(const RenderContext& ctx);
    // Mixes `phases` (kept by reference: they must outlive the next at()).
    void use(const std::vector<NbPhase>& phases) { mPhases = &phases; }
    // Reads the volumes' shares at x; false where no volume scatters there (then the first
    // volume's phase function stands in).
    bool at(const VolumeSet& vs, float3 x, float seconds = 0.0f);
    // p(cos theta), normalised over the sphere (1/sr).
    float eval(float cosTheta) const;
    // A direction whose cosine with `axis` has density eval (u0 picks the volume, then is reused).
    float3 sample(float3 axis, float u0, float u1, float u2) const;

private:
    const std::vector<NbPhase>* mPhases = nullptr;
    std::vector<float> mWeights;
    float mTotal = 0.0f;
};

}  // namespace nimbus
