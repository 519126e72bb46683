// MarchEightRays.h: the commonest camera march, eight rays at once, one per AVX2 lane.
//
// A grey medium in one volume lit by distant lights (a key, perhaps a fill: SingleScatter.cpp's
// marchGreyKeyLight and marchOneVolume<true, false>) is most of what lighters render with
// `single`. There, the scalar march spends its time on the brick walk's branches and on
// trilinear lookups and exponentials per sample (the step's and each light's), short dependent
// chains. Eight neighbouring pixels' rays cross nearly the same bricks, so here each lane
// carries one ray: per iteration, every live lane either takes its next sample (in an occupied
// brick: gathers for the density and each light's baked optical depth) or, in an empty
// brick, jumps its sample index past the brick's exit, as the scalar walk skips it. Same
// estimator, same lattice t_k = t_in + (k + jitter) dt, same cut-off: the lanes agree with the
// scalar march to float rounding (tests/single/test_eight_rays.cpp).
#pragma once

#include "InScatterGrid.h"
#include "SingleScatter.h"

// Built where the compiler targets AVX2 and FMA (CMakeLists.txt: x86-64-v3 where the build
// machine runs it); elsewhere every ray takes the scalar march.
#if defined(__AVX2__) && defined(__FMA__)
#define NIMBUS_EIGHT_RAY_MARCH 1
#else
#define NIMBUS_EIGHT_RAY_MARCH 0
#endif

namespace nimbus {

#if NIMBUS_EIGHT_RAY_MARCH
// Up to this many distant lights in the lanes (one accumulator each); more take the scalar march.
constexpr int kMaxEightRayLights = 8;
// Of those, at most this many environment lights read through their sky grids (SkyLight.h).
constexpr int kMaxEightRaySkies = 2;

// The grey march of SingleScatter.cpp (marchGreyKeyLight, marchOneVolume<true, false>) for n <= 8
// rays (o, d world, d unit; tFar their holdout distances as marchSingle's, or null) with their
// jitters, every used light distant and baked or an environment light's sky grid (`lights`,
// lightCount of them); perLight holds n runs of `perLightStride` floats. The caller has checked
// the case (SingleScatter.cpp). False, with nothing written, where a lane's march is too long
// for float sample indices, the pools too large for 32-bit gathers or the lights too many:
// then the caller marches the rays one by one.
// grid (or null): a field the same samples read too (InScatterGrid.h); each ray's
// int T sigma_s S dt per layer goes to gridL[i * layers + layer] (overwritten).
bool marchGreyDistantEight(const RenderContext& ctx, const VolumeData& vol, const LightEntry* const* lights,
                           int lightCount, int n, const float3* o, const float3* d, const float* tFar,
                           const float* jitter, CameraSample* out, float* perLight, size_t perLightStride,
                           const InScatterGrid* grid = nullptr, float3* gridL = nullptr);
#endif

}  // namespace nimbus
