// VrlCamera.h: the camera pass of virtual ray lights for one pixel sample.
//
//  - L0 and L1 exactly as the path tracer estimates them (kernels/pathtrace.cl, nbTracePath): a
//    free flight along the camera ray to its first scattering vertex (L0: the background times
//    the flight's throughput where it escapes), next-event estimation there for every light
//    (L1; an environment map by MIS of a map and a phase sample). Emission is gathered at every
//    tentative collision as the path tracer does; where a volume emits, the path continues with
//    phase sampling and Russian roulette to gather emission at orders 1 and up (no further
//    next-event estimation: orders 2 and up of the lights are the VRLs' and gatherPaths').
//  - L2plus from the lights: for each VRL of the iteration, one pair (u on the camera ray, v on
//    the VRL) from the joint distribution, weighted by Oppitz eq. 7.3's integrand over its pdf:
//        Phi sigma_s(v) f(theta_v) T(v) T(v, u) V(v, u) sigma_s(u) f(theta_u) T(u) / (w^2 pdf(u, v)),
//    the three transmittances by ratio tracking, V the shadow casters between v and u; each
//    times its BeamPathMis.h weight.
//  - L2plus by the path technique of BeamPathMis.h (gatherPaths), weighted against the VRLs.
#pragma once

#include "../pathtracer/PathtraceScene.h"
#include "BeamPathMis.h"
#include "JointSampling.h"
#include "VrlLightPass.h"
#include "VrlMedium.h"

#include <vector>

namespace nimbus::vrl {

// One pixel sample by scattering order, with per-light contributions (L1 + L2plus of each).
struct CameraSample {
    float3 L[3];
    float transmittance = 0;
    float depth = 0, hasDepth = 0;
    std::vector<float3> perLight;
    // The first scattering vertex (at t = depth): the throughput there and the volume that
    // scattered (-1: none).
    float3 scatterWeight;
    int scatterVolume = -1;
};

struct CameraSetup {
    const PathtraceScene* ps = nullptr;
    const VrlMedium* medium = nullptr;
    float3 background;
    int maxDepth = 0;  // scattering events; 0: unbounded
    JointKind kind = JointKind::Advanced;
    NbPhase cameraPhase;  // the advanced fit's phase function at u
    BeamPathMis mis;      // off unless set up
};

// Fills `out` (perLight sized to the lights) with L0, L1 and emission for the camera ray
// o + t d, t < tCamera (a holdout; INFINITY where none).
void traceCameraPath(const CameraSetup& s, float3 o, float3 d, float tCamera, NbRng& rng, CameraSample& out);

// Adds L2plus from every VRL to out.L[2] and out.perLight for the same camera ray.
void gatherVrls(const CameraSetup& s, float3 o, float3 d, float tCamera, const std::vector<Vrl>& vrls, NbRng& rng,
                CameraSample& out);

// Adds BeamPathMis.h's path technique to out.L[2] and out.perLight, from the first scattering
// vertex of `path` (traceCameraPath's sample of the same camera ray): orders 2 and up through the
// point, spot and distant lights and the iteration's light vertices, weighted against the VRL gathers.
void gatherPaths(const CameraSetup& s, float3 o, float3 d, float tCamera, const CameraSample& path, NbRng& rng,
                 CameraSample& out);

// The L2plus contribution of one VRL to the camera segment o + u d, u in [u0, u1] (for tests).
float3 gatherVrl(const CameraSetup& s, const Vrl& vrl, float3 o, float3 d, float u0, float u1, NbRng& rng);

}  // namespace nimbus::vrl
