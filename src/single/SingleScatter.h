// SingleScatter.h: the camera-ray march for L0 + L1 (Tessendorf eqs. 26-33).
#pragma once

#include "../render/CameraSample.h"
#include "../render/RenderContext.h"

#include "../../kernels/shared/rng.h"

namespace nimbus {

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
