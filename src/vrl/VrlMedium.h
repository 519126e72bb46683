// VrlMedium.h: the scene's media as the VRL estimator reads them on the CPU: the path tracer's
// flattened scene (PathtraceScene.h: the same volume descriptors, brick tables, pools and slot
// majorants) walked with kernels/shared/majorant.h, so that free flights, ratio tracking and
// Russian roulette are the path tracer's own (kernels/pathtrace.cl), here in C++:
//  - freeFlight: delta tracking with the spectral-tracking choice of events (Kutz et al. 2017),
//    the throughput w updated as in nbTracePath;
//  - transmittance: residual ratio tracking (Novak, Selle and Jarosz 2014, "Residual ratio
//    tracking for estimating attenuation in participating media"), with Russian roulette below
//    0.1 as nbRatioTransmittance. Over each stretch of constant majorant mu, the control extinction
//    sigma_c is the stretch's minorant, sum_v sigma_t,v min_v, min_v the least density value
//    of volume v's brick slot there (the smallest of the 9^3 values a trilinear lookup in the
//    slot reads, an exact lower bound, as the slot majorant is an exact upper one). Then
//        T = exp(-sigma_c l) prod_i (1 - (sigma_t(x_i) - sigma_c) / mu_r),
//    x_i tentative collisions at the residual rate mu_r = mu - min_channel(sigma_c), so each
//    factor lies in [0, 1]. Where a slot is homogeneous (sigma_t = sigma_c) the stretch takes
//    no collision and its factor is exact; plain ratio tracking there has mu = sigma_t (times
//    1 + 1e-5) and returns 0 or 1, a track-length estimate whose relative variance is
//    e^tau - 1: three of them in each VRL gather made a medium-density sphere's error mostly
//    this noise. The path tracer's kernel keeps plain ratio tracking.
//  - at / scattering: the coefficients at a point and sum over volumes of sigma_s(p) phase(cos)
//    (the VRL gather's two vertices);
//  - span: where a ray is inside some volume's active box (the extent of a VRL or of the
//    camera segment the gather samples).
// Velocity blur (ptscene.h): every read is at one shutter time, `seconds`, set by the integrator
// between iterations (one time per iteration, shared by its light and camera paths, so that the
// VRLs and the rays gathering from them see the same medium).
// The OpenCL functions are not shared with this file because kernels/pathtrace.cl keeps them
// private to the kernel (their address-space qualifiers); the loops here mirror them line for line.
#pragma once

#include "../../kernels/shared/majorant.h"
#include "../../kernels/shared/rng.h"
#include "../pathtracer/PathtraceScene.h"

#include <vector>

namespace nimbus::vrl {

struct FlightResult {
    bool scattered = false;
    float t = 0;      // where it scattered
    int volume = -1;  // which volume scattered
};

struct MediumPoint {
    float3 sigmaT, sigmaS;
    float3 scatter;  // sum_v sigma_s,v phase_v(cos theta)
};

class VrlMedium {
public:
    // residual: build the slot minorants that transmittance's residual ratio tracking reads (one
    // pass over the density bricks); false for a user that estimates no transmittance (WKB's
    // radiance cache traces free flights only), whose transmittance would be plain ratio tracking.
    explicit VrlMedium(const PathtraceScene& ps, bool residual = true);

    // Delta tracking from o along d (unit) over [0, tEnd]: a real scattering event, or none (the
    // ray left the volumes or reached tEnd). w: the RGB throughput, updated (Kutz et al. 2017).
    // emission: where non-null, w j / mu is added at every tentative collision.
    FlightResult freeFlight(float3 o, float3 d, float tEnd, float3& w, NbRng& rng, float3* emission) const;

    // Ratio-tracking estimate of the RGB transmittance along o + t d, t in [0, tMax].
    float3 transmittance(float3 o, float3 d, float tMax, NbRng& rng) const;

    // The coefficients at p, summed over the volumes (RGB, 1/m), and sum_v sigma_s,v(p)
    // phase_v(cosTheta) (1/(m sr)).
    MediumPoint at(float3 p, float cosTheta) const;
    float3 scattering(float3 p, float cosTheta) const { return at(p, cosTheta).scatter; }

    // [t0, t1]: the part of [tMin, tMax] where o + t d is inside some volume's active box;
    // false when there is none.
    bool span(float3 o, float3 d, float tMin, float tMax, float& t0, float& t1) const;

    // The phase function of the volume with the largest scattering majorant (the advanced joint
    // distribution's fit where the medium at a point is not known yet).
    NbPhase dominantPhase() const;
    // The shutter time of every read that follows, seconds after the frame's (0 without velocity
    // blur). Not to be called while another thread reads the medium.
    void setShutterSeconds(float seconds) { mSeconds = seconds; }
    float shutterSeconds() const { return mSeconds; }

    NbPhase phase(int volume) const { return mPs->volumes[size_t(volume)].phase; }
    bool hasEmission() const { return mPs->emission; }
    int volumeCount() const { return mCount; }

private:
    // The control extinction (RGB, 1/m) over the stretch the walk `it` is on: see transmittance.
    float3 control(const NbMajorantIter& it) const;

    const PathtraceScene* mPs;
    int mCount;
    // Per volume, the least density value of each brick slot (its density grid's slot order);
    // empty where the volume moves by velocity (its lookups are displaced) or its density is a
    // NanoVDB grid: no control there.
    std::vector<std::vector<float>> mSlotMin;
    float mSeconds = 0;
};

// Counts the medium's work on the calling thread while `counter` is set (nullptr: stop): one
// unit per majorant segment walked and per density read. SampleAllocation.h's deterministic
// stand-in for time, which would make the allocation, and so the image, depend on the machine.
void setWorkCounter(long long* counter);

// Uniform in (0, 1]: safe for -log (pathtrace.cl's nbRngOpen).
inline float rngOpen(NbRng& rng)
{
    return 1.0f - nbRngNext(&rng);
}

}  // namespace nimbus::vrl
