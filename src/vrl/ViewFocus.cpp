#include "ViewFocus.h"

#include "../core/StepCount.h"
#include "CameraLattice.h"
#include "PhaseMixture.h"
#include "../single/ScatterPoints.h"
#include "../scene/KernelScene.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace nimbus::vrl {

EmissionFocus findViewFocus(const RenderContext& ctx, float cellSize, float boundsRadius)
{
    EmissionFocus focus;
    if (!ctx.scene || ctx.volumes.empty() || !(boundsRadius > 0.0f))
        return focus;
    const CameraLattice lattice(ctx.scene->camera, kFocusRays);
    const std::vector<NbPhase> phases = PhaseMix::phasesOf(ctx);
    // Each row of the lattice marched on its own, the rows' sums combined in row order: the same
    // focus whatever the thread count.
    struct Row {
        float3 lo = make_float3(INFINITY, INFINITY, INFINITY), hi = make_float3(-INFINITY, -INFINITY, -INFINITY);
        double sigmaTMax = 0.0, wSum = 0.0, omegaSum = 0.0, gSum = 0.0;
    };
    std::vector<Row> rows(size_t(lattice.ny));
    tbb::parallel_for(0, lattice.ny, [&](int py) {
        throwIfStopped(&ctx.stop);
        Row& r = rows[size_t(py)];
        std::vector<float> pw(phases.size(), 0.0f);
        std::vector<Span> spans;
        for (int px = 0; px < lattice.nx; ++px) {
            float3 o, d;
            lattice.ray(px, py, o, d);
            ctx.volumes.spans(o, d, 0.0f, 1e30f, 1.0f, spans);
            double T = 1.0;  // the grey (channel-mean) transmittance to the camera
            for (size_t si = 0; si < spans.size() && T >= double(kFocusMinTransmittance); ++si) {
                const Span& sp = spans[si];
                const float len = sp.t1 - sp.t0;
                const int n = stepCount(len, sp.step);
                const float dt = len / float(n);
                for (int k = 0; k < n && T >= double(kFocusMinTransmittance); ++k) {
                    const float3 x = o + d * (sp.t0 + (float(k) + 0.5f) * dt);
                    std::fill(pw.begin(), pw.end(), 0.0f);
                    const MediumSample s = ctx.volumes.sample(x, pw.data());
                    const double st = (double(s.sigma_t.x) + double(s.sigma_t.y) + double(s.sigma_t.z)) / 3.0;
                    const double ss = (double(s.sigma_s.x) + double(s.sigma_s.y) + double(s.sigma_s.z)) / 3.0;
                    if (ss > 0.0) {
                        r.lo = fmin(r.lo, x);
                        r.hi = fmax(r.hi, x);
                        r.sigmaTMax = std::max(r.sigmaTMax, st);
                        // The largest albedo of any channel: the widest spread.
                        double omega = 0.0;
                        for (int c = 0; c < 3; ++c) {
                            const double t = double((&s.sigma_t.x)[c]);
                            omega = std::max(omega, t > 0.0 ? std::min(1.0, double((&s.sigma_s.x)[c]) / t) : 1.0);
                        }
                        const double g = mixedMeanCosine(phases, pw.data());
                        const double w = ss * T * double(dt);
                        r.wSum += w;
                        r.omegaSum += w * omega;
                        r.gSum += w * g;
                    }
                    T *= std::exp(-st * double(dt));
                }
            }
        }
    });
    float3 lo = make_float3(INFINITY, INFINITY, INFINITY), hi = -lo;
    double sigmaTMax = 0.0, wSum = 0.0, omegaSum = 0.0, gSum = 0.0;
    for (const Row& r : rows) {
        lo = fmin(lo, r.lo);
        hi = fmax(hi, r.hi);
        sigmaTMax = std::max(sigmaTMax, r.sigmaTMax);
        wSum += r.wSum;
        omegaSum += r.omegaSum;
        gSum += r.gSum;
    }
    if (!(wSum > 0.0) || !(sigmaTMax > 0.0))
        return focus;  // the camera sees no medium
    const double omega = omegaSum / wSum, g = gSum / wSum;
    const double k = 3.0 * (1.0 - omega) * (1.0 - g * omega);
    const double diffusion = k > 0.0 ? 1.0 / (sigmaTMax * std::sqrt(k)) : INFINITY;
    const double margin = std::max(2.0 * double(cellSize), double(kFocusDiffusionLengths) * diffusion);
    const double radius = 0.5 * double(length(hi - lo)) + margin;
    if (!(radius <= double(kFocusMaxRadiusFraction) * double(boundsRadius)))
        return focus;  // most of the medium is in reach of the view: nothing to gain
    focus.active = true;
    focus.centre = (lo + hi) * 0.5f;
    focus.radius = float(radius);
    return focus;
}

}  // namespace nimbus::vrl
