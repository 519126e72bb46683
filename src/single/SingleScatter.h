// SingleScatter.h: the camera-ray march for L0 + L1 (Tessendorf eqs. 26-33).
#pragma once

#include "../render/CameraSample.h"
#include "../render/RenderContext.h"
#include "InScatterGrid.h"

#include "../../kernels/shared/rng.h"

namespace nimbus {

// Marches one camera ray o + t d (d unit). `rng` supplies the stratified jitter (sec. 4.1.1)
// and light samples. perLight (3 * lights floats, zeroed by the caller) receives each light's
// L1 contribution. tFar: where a holdout stops the ray (docs/geometry.md; the march takes no
// sample at or past it and the ray sees no background), INFINITY for none. seconds: the ray's
// shutter time after the frame's, at which moving volumes are read (VolumeSet::sampleAt).
void marchSingle(const RenderContext& ctx, float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight,
                 float tFar = INFINITY, float seconds = 0.0f);

// marchSingle for n rays at once (a row of a tile): the same samples, eight rays per step in
// the common case where this build can (MarchEightRays.h). perLight holds n runs of 3 * lights
// floats, zeroed by the caller. tFar: n holdout distances as for marchSingle, or null for none.
// seconds: n shutter times as for marchSingle, or null (the frame's time).
// grid (or null): a field of in-scattered radiance (InScatterGrid.h) that the eight-ray march
// reads with its own samples: ray i's int T sigma_s S dt per layer goes to
// gridL[i * grid->layers + layer] with gridRead[i] = 1 where the lanes marched it; where they did
// not, gridRead[i] = 0 and the caller reads the field itself.
void marchSingleRays(const RenderContext& ctx, int n, const float3* o, const float3* d, NbRng* rng, CameraSample* out,
                     float* perLight, const float* tFar = nullptr, const float* seconds = nullptr,
                     const InScatterGrid* grid = nullptr, float3* gridL = nullptr, unsigned char* gridRead = nullptr);

// Test hooks, for tests/single/test_marcher_reference.cpp, which checks every specialised loop
// against the general one ray by ray.
// The loop a ray that meets the volumes takes: through marchSingle (batch false) or through
// marchSingleRays with more than one ray (batch true). The lanes may still hand a batch back to
// the scalar loops (MarchEightRays.h: marches too long for float indices, pools too large).
enum class SingleRoute { General, GreyKeyLight, GreyKeySky, Grey, OneDistant, Chromatic, GreyDistantEight };
SingleRoute singleRouteOf(const RenderContext& ctx, bool batch);
// marchSingle through the general loop, whatever the scene. With one volume, its samples lie on
// the specialised loops' lattice, t_k = t_in + (k + jitter) dt from the ray's entry into the
// occupied bricks' bounds (walkVolume, BrickWalk.h), rather than on the general loop's own
// lattice per span: then the two marches take the same samples and agree to float rounding.
void marchSingleGeneralReference(const RenderContext& ctx, float3 o, float3 d, NbRng& rng, CameraSample& out,
                                 float* perLight);

}  // namespace nimbus
