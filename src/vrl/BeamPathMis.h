// BeamPathMis.h: multiple importance sampling of the last two scattering events before the
// camera, which vrl samples two ways. A path reaches the camera from a light vertex x (a point,
// spot or distant light, or a scattering vertex of a light path) through v and then u on the
// camera ray:
//  - the beam technique (VrlCamera's gather): the VRL leaving x along omega, and the joint pair
//    (u on the camera ray, v on the VRL). Its density in du dV(v), dV = t^2 dt domega, is
//        p_omega(omega) p_joint(u, t) / t^2,   t = |v - x|,
//    p_omega the light pass's direction pdf at x: N P_light p_light(omega) for a point or spot
//    light (N paths an iteration, each leaving light l with probability P_light), the phase
//    function f_x for a scattering vertex (one VRL leaves it). A distant light's lines are drawn
//    across a disc: there the density is N P_light p_disc p_joint(u, t) (dV = dA dt), times the
//    direction's pdf, which both techniques share and which cancels;
//  - the path technique (gatherPaths in VrlCamera.h): the pixel's first camera path, the one that
//    gathers from the VRLs, scatters at u (its free flight), samples the phase function, flies
//    to v and connects v to x: next-event estimation to the light (point, spot and distant
//    lights; the VRLs leaving environment, rect and sphere lights keep weight 1), or a connection
//    to one of the K scattering vertices of the iteration's light paths chosen uniformly (a
//    virtual point light). Its density is about
//        c sigma_t(u) fbar_u(cos) sigma_t(v) / w^2,   w = |v - u|,   c = 1 for a light, 1 / K for a vertex,
//    fbar_u the sigma_s-weighted phase function at u: the free flights' transmittances are left
//    out, a deterministic stand-in for the pdf, exact where the media are thin.
// Each technique's estimate is multiplied by the balance heuristic of the two densities (Veach
// 1997, sec. 9.2; the same weights on both sides, so they sum to one for every path and the sum
// stays unbiased whatever the stand-in). Why: the beam technique's variance is unbounded where a
// VRL runs nearly parallel to the camera ray a few millimetres from it (its gather is about
// 1 / distance; docs/vrl.md, "Where it wins and where it loses"), exactly where the camera path's
// phase sample follows the beam; the path technique's is unbounded near x (the 1 / t^2 of the
// connection), exactly where the VRLs leaving x are dense. The pair is Krivanek et al. 2014's
// ("Unifying points, beams, and paths in volumetric light transport simulation") beam-beam and
// path estimators for the last two events.
#pragma once

#include "../pathtracer/PathtraceScene.h"
#include "JointSampling.h"
#include "VrlLightPass.h"
#include "VrlMedium.h"

#include <cmath>
#include <vector>

namespace nimbus::vrl {

class BeamPathMis {
public:
    // Off (every VRL keeps weight 1, no path technique) until set up.
    BeamPathMis() = default;
    BeamPathMis(const PathtraceScene& ps, const VrlMedium& medium, const LightPass& lights, JointKind kind,
                NbPhase cameraPhase, int lightPaths);

    bool active() const { return mLights != nullptr; }
    // The iteration's VRLs (kept by pointer until the next call): the light vertices to connect to.
    void setIteration(const std::vector<Vrl>& vrls);

    // Whether light i's paths are shared between the techniques (point, spot and distant lights).
    bool coversLight(int light) const;
    // The light vertices (VRLs of order >= 1, whose origins are scattering vertices).
    int lightVertexCount() const { return int(mVertices.size()); }
    const Vrl& lightVertex(int k) const { return (*mVrls)[size_t(mVertices[size_t(k)])]; }

    // The beam technique's density of a gather's own sample from `vrl` (v at distance t along it,
    // jointPdf the pair's pdf in (u, t)).
    double beamDensity(const Vrl& vrl, float t, double jointPdf) const;
    // The beam technique's density of the path from light i (or, with light < 0, from the origin
    // of `vertex`) through v to u on the camera segment o + u d, u in [u0, u1]; 0 where no VRL
    // reaches v. travel: the direction a distant light's light travels along (unused otherwise).
    double beamDensityTo(int light, const Vrl* vertex, float3 travel, float3 o, float3 d, float u0, float u1, float u,
                         float3 v) const;
    // The path technique's stand-in density: atU read at u with the cosine between the camera ray
    // and the direction from u to v, atV at v, dist = |v - u|; toLight: next-event estimation
    // (count 1) rather than a connection to a light vertex (count 1 / K).
    double pathDensity(const MediumPoint& atU, const MediumPoint& atV, float dist, bool toLight) const;

private:
    const PathtraceScene* mPs = nullptr;
    const VrlMedium* mMedium = nullptr;
    const LightPass* mLights = nullptr;
    JointKind mKind = JointKind::Advanced;
    NbPhase mCameraPhase{0, 0, 0, 0};
    int mLightPaths = 0;  // N
    const std::vector<Vrl>* mVrls = nullptr;
    std::vector<int> mVertices;  // indices in *mVrls of the VRLs of order >= 1
};

// The balance heuristic's weight of the technique with density `mine` against `other`.
inline float balanceWeight(double mine, double other)
{
    const double sum = mine + other;
    return sum > 0.0 && std::isfinite(sum) ? float(mine / sum) : (mine > 0.0 ? 1.0f : 0.0f);
}

}  // namespace nimbus::vrl
