// SingleScatter.h: the camera-ray march for L0 + L1 (Tessendorf eqs. 26-33).
#pragma once

#include "RenderContext.h"

#include "../../kernels/shared/rng.h"

namespace nimbus {

// What one camera sample gathers. Radiance in W/(m^2 sr); perLight has 3 floats per light.
struct CameraSample {
    Rgb L0 = splat(0.0f);      // emission and background seen through the medium (eq. 26)
    Rgb L1 = splat(0.0f);      // single scattering (eqs. 31-33)
    Rgb L2plus = splat(0.0f);  // multiple scattering (wkb only)
    Rgb transmittance = splat(1.0f);
    float depth = 0.0f;        // opacity-weighted mean distance along the ray, metres; 0 if empty
    float opacity = 0.0f;      // the ray's opacity summed step by step: the depth's weight in a pixel
};

// Marches one camera ray o + t d (d unit). `rng` supplies the stratified jitter (sec. 4.1.1)
// and light samples. perLight (3 * lights floats, zeroed by the caller) receives each light's
// L1 contribution.
void marchSingle(const RenderContext& ctx, float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight);

// marchSingle for n rays at once (a row of a tile): the same samples, eight rays per step in
// the common case where this build can (MarchEightRays.h). perLight holds n runs of 3 * lights
// floats, zeroed by the caller.
void marchSingleRays(const RenderContext& ctx, int n, const float3* o, const float3* d, NbRng* rng, CameraSample* out,
                     float* perLight);

}  // namespace nimbus
