// SkyTail.h: the part of an environment light's single scattering that the sky grid leaves to the
// camera march (SkyLight::tailAlong): the phase function's forward peak f = p_(J+1) and its bands
// above the grid's order J, the delta-M split.
//
// That part is forward-peaked, so the light it scatters at y toward the camera comes from
// directions near the ray's own, through the medium behind y: with that transmittance taken as
// the ray's T(y, end) for all of it,
//     int T(0, t) sigma_s(t) T(t, end) L_tail(d) dt = L_tail(d) T int sigma_s dt,
// since T(0, t) T(t, end) = T(0, end) = T for every t: one product after the march instead of a
// shadow ray per step. tests/validation/sky_grid_accuracy.py measures what it leaves. A march
// stopped at the transmittance cut-off adds nothing.
#pragma once

#include "../render/CameraSample.h"
#include "../render/RenderContext.h"

namespace nimbus {

// Whether the sky behind the medium reaches the camera ray: not where the ray is held out, nor
// where a shadow caster lies on it beyond the volumes' entry (a caster inside the medium then
// blocks the whole ray's tail, before it as well as behind it; docs/single-scattering.md).
bool skyBehindOpen(const RenderContext& ctx, float3 o, float3 d, bool heldOut);

// Adds each used sky's sum over volumes v of T L_tail_v(d) tauS[s nVolumes + v] to out.L1 and its
// light AOV (perLight: 3 floats per light of ctx): tauS is volume v's int sigma_s dt along the ray
// (per sky slot s, skies in ctx.lights' order), T the ray's transmittance at the march's end.
void addSkyTails(const RenderContext& ctx, float3 d, Rgb T, const Rgb* tauS, size_t nVolumes, CameraSample& out,
                 float* perLight);

// One volume: int sigma_s dt = (sigma_s / sigma_t) (-ln T) per channel, from the march's own
// transmittance T (the sum of its steps' optical depths); then addSkyTails where the sky behind
// is open.
void addSkyTailsOneVolume(const RenderContext& ctx, const VolumeData& vol, float3 o, float3 d, Rgb T, bool heldOut,
                          CameraSample& out, float* perLight);

}  // namespace nimbus
