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

// Test hooks, for tests/render/test_marcher_reference.cpp, which checks every specialised loop
// against the general one ray by ray.
// The loop a ray that meets the volumes takes: through marchSingle (batch false) or through
// marchSingleRays with more than one ray (batch true). The lanes may still hand a batch back to
// the scalar loops (MarchEightRays.h: marches too long for float indices, pools too large).
enum class SingleRoute { General, GreyKeyLight, Grey, OneDistant, Chromatic, GreyDistantEight };
SingleRoute singleRouteOf(const RenderContext& ctx, bool batch);
// marchSingle through the general loop, whatever the scene. With one volume, its samples lie on
// the specialised loops' lattice, t_k = t_in + (k + jitter) dt from the ray's entry into the
// occupied bricks' bounds (walkVolume, BrickWalk.h), rather than on the general loop's own
// lattice per span: then the two marches take the same samples and agree to float rounding.
void marchSingleGeneralReference(const RenderContext& ctx, float3 o, float3 d, NbRng& rng, CameraSample& out,
                                 float* perLight);

}  // namespace nimbus
