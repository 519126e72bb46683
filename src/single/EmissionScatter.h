// EmissionScatter.h: emission as a light source of single scattering (issue 13, item 4; Tessendorf
// sec. 3.4.4: the source term of eq. 31 holds every radiance arriving at the point, emitted
// included). Fire lights its smoke:
//
//     L1_emission = int ds T(0,s) b(s) int dw' p(w' . d) Le(x(s), w')
//
// with Le(x, w') the emitted radiance arriving at x from w' (the integral of T * emission along
// x + t w'). Per camera ray, ScatterPoints draws `render.emission_samples` points by T b and each a
// direction by the phase function about d (weight 1), and emittedRadiance marches Le. Unbiased for
// the march's piecewise-constant medium; it goes to L1 (the path tracer's L1 counts emission met
// after one scattering the same way, docs/pathtracer.md), to no light's AOV.
#pragma once

#include "../render/CameraSample.h"
#include "../render/RenderContext.h"
#include "ScatterPoints.h"

#include <vector>

namespace nimbus {

// Emitted radiance arriving at x from direction u (travelling along -u), W/(m^2 sr): the integral
// of T * emission along x + t u (eq. 26's source term), midpoint steps of `stepFraction` voxels, up
// to the first shadow caster.
// seconds: the shutter time at which moving volumes are read (VolumeSet::sampleAt). A raised
// `stop` (RenderControl.h) ends the march early, its value then to be discarded.
Rgb emittedRadiance(const VolumeSet& vs, float3 x, float3 u, float stepFraction, const EmbreeScene* casters,
                    float seconds = 0.0f, const StopFlag* stop = nullptr);

class EmissionScatter {
public:
    explicit EmissionScatter(const RenderContext& ctx);
    // Whether the scene has emission to scatter (else add does nothing).
    bool active() const { return mActive; }
    // Adds emission's single scattering along o + s d, s in [0, tFar), to out.L1. Draws its numbers
    // from rng. seconds: the ray's shutter time (velocity blur, VolumeSet::sampleAt).
    void add(float3 o, float3 d, NbRng& rng, CameraSample& out, float tFar = INFINITY, float seconds = 0.0f) const;

private:
    const RenderContext* mCtx;
    bool mActive = false;
    int mSamples = 1;
    std::vector<NbPhase> mPhases;
};

}  // namespace nimbus
