// ScatterSource.h: single scattering's source at one point, the integrand of marchSingle's L1
// (Tessendorf eq. 31) read at a point instead of summed along a ray.
//
// At x, for a viewer looking along d (light leaves x toward the viewer, along -d), the light of
// every source that reaches x unscattered, scattered there toward the viewer, per unit
// scattering coefficient:
//
//     S(x, d) = sum_lights p(w_l . d) L_l T_l(x)                        (delta and area lights)
//             + sum_skies sum_jm (p_j - f) L^jm(x) y_jm(-d)              (the sky grid, SkyLight.h)
//             + sum_skies T(x, end) L_tail(d)                            (its forward peak, SkyTail.h)
//
// in W/(m^2 sr) (p in 1/sr, L_l T_l an irradiance): sigma_s(x) S(x, d) ds is the radiance a step
// ds at x sends along -d. Read as the marches read it: a baked light's transmittance from its
// shadow map on the voxels, marched back toward the light inside a stiff brick
// (stiffOpticalDepth, StiffVoxels.h), the sky grids trilinear, several volumes' phase functions
// mixed by scattering coefficient. `behind` is T(x, end), the transmittance from x to where the
// viewer's ray leaves the medium: the sky tail's share (0 where something holds the ray out, or
// where the ray's whole transmittance is under render.tolerance: the march stops there and adds
// no tail).
//
// So int_0^tEnd T(0, s) sigma_s(s) S(x(s), d) ds, marchSingle's L1 along o + s d, is estimated
// without bias (for the march's piecewise-constant medium) by W S(x, d) at one point drawn by
// ScatterPointSampler (W = T b / pdf): what wkb's traced order 2 gathers at the end of each of
// its secondary directions (wkb/TracedOrder2.h).
#pragma once

#include "../render/RenderContext.h"

#include "../../kernels/shared/rng.h"

namespace nimbus {

// S(x, d) as above; each light's part is added to perLight[3 i + c] (3 floats per light of ctx).
// Draws from rng only for lights that are not deltas (an area light's point). seconds: the
// shutter time, at which moving volumes and lights are read (VolumeSet::sampleAt).
Rgb singleScatterSource(const RenderContext& ctx, float3 x, float3 d, Rgb behind, NbRng& rng, float* perLight,
                        float seconds = 0.0f);

}  // namespace nimbus
