// VrlIntegrator.h: "method": "vrl", virtual ray lights (Novak et al. 2012; Oppitz 2018, ch. 7-8;
// docs/vrl.md), on the CPU with TBB.
//
// One iteration is one sample per pixel: a light pass traces render.vrl_paths light paths from
// the scene's lights (chosen by power) with the path tracer's delta tracking, majorants and
// Russian roulette, each path segment a virtual ray light; then every pixel's camera sample
// gathers L0 and L1 as the path tracer does (a free flight to the first scattering vertex and
// next-event estimation there, on as many camera paths as a pilot before the render finds best:
// SampleAllocation.h) and scattering orders 2 and up from every VRL of the iteration
// by joint importance sampling of a point pair (JointSampling.h). Iterations are independent, so
// their per-pixel running means and variance are the path tracer's (Skanberg sec. 6.9), in the
// same accumulator layout (ptscene.h), and checkpoints, resume and sample splits reuse
// PathtraceState.h. Random numbers: a camera sample draws from (seed, pixel, iteration) as the
// path tracer's does, a light path from (seed', path, iteration): any thread count gives the same
// image.
#pragma once

#include "../pathtracer/Pathtracer.h"
#include "../render/Film.h"
#include "../render/Integrator.h"
#include "../render/RenderContext.h"

namespace nimbus {

// L0, L1, L2plus and the variance, as the path tracer.
IntegratorTraits vrlTraits();

// Renders ctx's scene with virtual ray lights into `film` (AOVs as renderPathtrace's). Stopping
// rules, checkpoints, resume and sample splits follow `pt` and the scene exactly as the path
// tracer's (pt.device, localSize, samplesPerPass and globalMajorant do not apply; pt.stats gets
// the counts and times that do, device "cpu"). Throws Error, Cancelled.
void renderVrl(const RenderContext& ctx, Film& film, const RenderControl& control, const PathtraceOptions& pt = {});

class VrlIntegrator final : public Integrator {
public:
    VrlIntegrator(const RenderContext& ctx, PathtraceOptions options) : mCtx(&ctx), mOptions(std::move(options)) {}
    Drive drive() const override { return Drive::WholeImage; }
    void renderImage(Film& film, const RenderControl& control) override { renderVrl(*mCtx, film, control, mOptions); }

private:
    const RenderContext* mCtx;
    PathtraceOptions mOptions;
};

}  // namespace nimbus
