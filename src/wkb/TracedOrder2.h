// TracedOrder2.h: the second scattering order of the lights' L2+, by Monte Carlo samples per
// camera ray (docs/wkb.md "Order 2, traced"; the research note's remedy 6, "low orders exactly").
//
// Along the camera ray o + s d (d unit), light that scattered exactly twice reaches the camera as
//
//     L2 = int ds T(0,s) b(s) int dw' p(w' . d) L1(x(s), w')                  (Tessendorf eq. 26
//                                                                               with eq. 31's L1
//                                                                               as the source)
// where L1(x, w') is the single-scattered radiance arriving at x from direction w' (the radiance
// single's march gathers along the ray x + t w'), and p(w' . d) the phase function for light
// travelling along -w' scattered into -d. Per camera ray, render.wkb_order2_samples samples: s
// with probability proportional to T(0,s) b(s) (ScatterPoints.h: one march, stratified draws), w'
// by one-sample multiple importance sampling between the phase lobe about d and, for each light
// with a position or direction, the phase lobe about the direction toward that light (where
// forward-scattered L1 is brightest); then L1(x, w'), the integral of T b S along x + t w' (S the
// source of single scattering at a point, ScatterSource.h), by one point of that ray drawn by T b
// (a second ScatterPointSampler march). The estimate is unbiased for the piecewise-constant medium
// of the marches (the quadrature every march here uses), and the straight-line reduction's error
// at order 2 (no boundary, no curvature) is gone.
//
// A point or spot light's L1 along x + t w' falls off as 1 / r^2 from the light: where w' passes
// near it, the points drawn by T b find a spike that they sample with infinite variance (a point
// light inside a haze box: beauty relMSE 0.33 at 4 spp, 0.14 at 16, against the path tracer).
// Along each w' that passes near such a light (its equi-angular density's peak at least half the
// largest density of the T b draws, the path tracer's test, equiangular.h), one more point is
// drawn equi-angularly toward it (Kulla and Fajardo 2012; Oppitz eqs. 7.7-7.8) and that light's
// part of S is combined by the balance heuristic over the K draws and that one,
// T b S_l / (K p_Tb(t) + p_equi(t)) at every point of either technique; the other lights' parts
// stay with the T b draws alone. Unbiased (the weights sum to 1 at every t).
#pragma once

#include "../render/CameraSample.h"
#include "../render/RenderContext.h"
#include "../single/ScatterPoints.h"

#include "../../kernels/shared/rng.h"

#include <vector>

namespace nimbus::wkb {

class TracedOrder2 {
public:
    explicit TracedOrder2(const RenderContext& ctx);

    // Adds the mean of render.wkb_order2_samples samples of order 2 along o + s d, s in [0, tFar),
    // to out.L2plus and each light's part to perLight[3 i + c]. Draws its numbers from rng.
    // seconds: the ray's shutter time, at which moving volumes are read (VolumeSet::sampleAt).
    // Returns the march of the camera ray that the points were drawn from (this thread's, valid
    // until its next call; RadianceGrid.h's readOrders3 integrates orders 3+ over its steps), or
    // null where the ray meets no scattering medium or the render was stopped.
    const ScatterPointSampler* add(float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight,
                                   float tFar = INFINITY, float seconds = 0.0f) const;

private:
    // One of mSamples draws at the traced point p (d the camera ray's direction).
    void sample(const ScatterPoint& p, float3 d, PhaseMix& phase, NbRng& rng, CameraSample& out, float* perLight,
                float seconds) const;

    const RenderContext* mCtx;
    int mSamples = 1;              // per camera ray, sharing one march
    std::vector<NbPhase> mPhases;  // per volume
    std::vector<int> mLobeLights;  // lights whose direction gets a sampling lobe
    std::vector<int> mPointLights;  // point and spot lights: equi-angular points along w'
};

}  // namespace nimbus::wkb
