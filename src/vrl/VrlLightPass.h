// VrlLightPass.h: the light pass of virtual ray lights (Novak et al. 2012, sec. 4; Oppitz 2018,
// sec. 7.2 and Algorithm 8.x "trace photon" with segments): light paths from the scene's lights,
// each segment a virtual ray light (VRL).
//
// A path starts at a light chosen with probability proportional to its power, from a point and
// direction sampled on the light with flux W / (P_light N) (N paths per iteration), and is traced
// with the path tracer's free flights (VrlMedium::freeFlight: delta tracking on the brick
// majorants, spectral tracking of the RGB throughput w) and its Russian roulette (from the third
// scattering event on, survival min(1, max w)). Every segment, the one leaving the light and the
// one after each scattering event, becomes a VRL with flux Phi w.
//
// Why a VRL reaches to where the ray leaves the volumes (or meets a shadow caster) rather than to
// the next scattering event: its transmittance T(origin -> v) is then estimated at gather time by
// ratio tracking, which is unbiased for any medium, chromatic ones included. Ending it at the
// next scattering event instead would count T(v) twice (once as the probability of reaching v,
// once in the gather) unless the gather dropped T(v), which is exact only for grey media tracked
// without weights. The path itself continues from its next scattering event as the path tracer's.
//
// Light emission (W per path before the division by P_light N):
//  - point: uniform direction, W = 4 pi I;  spot: uniform in the outer cone, W = 2 pi (1 - cos_o) I
//    falloff;
//  - distant and environment: a direction (the cone of a distant light with an angle; the map's
//    distribution, or uniform), then a point on the disc of radius R (the volumes' bounding
//    sphere) across it: W = (L / pdf) pi R^2, L / pdf as in light.h;
//  - rect: a uniform point and a cosine-weighted direction on the emitting side, W = pi A L;
//  - with a focus (setFocus), distant, environment, point and spot lights aim a share of the paths
//    at it, W divided by the mixture's pdf instead;
//  - sphere: a uniform point and a cosine-weighted direction outward, W = pi 4 pi r^2 L; where a
//    volume reaches inside the sphere, half the paths leave the surface inward instead (a point
//    inside sees radiance L from every direction, light.h) and end at its far side, W doubled.
#pragma once

#include "../pathtracer/PathtraceScene.h"
#include "../render/RenderContext.h"
#include "JointSampling.h"
#include "ViewFocus.h"
#include "VrlMedium.h"

#include <vector>

namespace nimbus::vrl {

struct Vrl {
    float3 origin;         // where the segment starts: the light, or a scattering vertex (T from here)
    float3 dir;            // unit, the direction light travels
    float t0 = 0, t1 = 0;  // the part inside the volumes' boxes, before any shadow caster
    float3 flux;           // Phi w, W (already divided by P_light N)
    NbPhase phase;         // the phase function that scattered the light into it (the fit's at v)
    float3 inDir;          // order >= 1: the direction the light path arrived at origin along
    int order = 0;         // scattering events before it: 0 leaves the light
    int light = 0;         // index in PathtraceScene::lights (per-light AOVs)
};

// The two lines a gather samples: the camera segment o + u d, u in [u0, u1], and the VRL.
inline LinePair gatherLines(float3 o, float3 d, float u0, float u1, const Vrl& vrl)
{
    LinePair lines;
    lines.oU = o;
    lines.dU = d;
    lines.u0 = u0;
    lines.u1 = u1;
    lines.oV = vrl.origin;
    lines.dV = vrl.dir;
    lines.v0 = vrl.t0;
    lines.v1 = vrl.t1;
    return lines;
}

class LightPass {
public:
    // maxDepth: scene.render.max_depth (0: unbounded); a VRL of order k carries paths with k + 2
    // scattering events and is kept only where that is allowed.
    LightPass(const RenderContext& ctx, const PathtraceScene& ps, const VrlMedium& medium, int maxDepth);

    // The VRLs of `paths` light paths of one iteration, in path order (any thread count gives
    // the same list). seed: scene.render.seed. Once the render is stopped (the context's
    // StopFlag, RenderControl.h) the paths end early: a thick medium's paths can take millions
    // of events; the caller sees the flag and discards the list.
    std::vector<Vrl> trace(uint32_t seed, uint32_t iteration, int paths) const;
    // Path `path` of trace's `paths` alone, its segments in order appended to `out`: for a caller
    // that consumes each path as it is traced (WKB's radiance cache, Orders3Grid.cpp).
    void tracePath(uint32_t seed, uint32_t iteration, int path, int paths, std::vector<Vrl>& out) const;

    bool empty() const { return mCdf.empty(); }

    // Aims a share of the paths at `focus` (ViewFocus.h; WKB's orders-3+ cache only): distant and
    // environment lights draw the line's point on the disc across the direction from the focus's
    // disc with probability 1 - kFocusDefensive, else from the volumes' (as without a focus); point
    // and spot lights draw the direction from the cone that subtends the focus likewise, else as
    // without. Each path's W divides by the mixture's pdf (both parts, whichever drew it): the
    // estimate stays unbiased; paths away from the focus are fewer and carry more flux. Rect and
    // sphere lights, lights inside the focus, and spot lights whose own cone is narrower than the
    // focus's are not aimed.
    void setFocus(const EmissionFocus& focus) { mFocus = focus; }
    // Without a focus, point and spot lights outside the volumes' bounding sphere aim at it
    // instead, the same way (WKB's cache: a lamp a few metres from a small cloud sent most of its
    // uniform directions past it).
    void setAimAtVolumes(bool aim) { mAimAtVolumes = aim; }
    float boundsRadius() const { return mRadius; }

    // The pdf (1/sr) of the direction `dir` of a path leaving point or spot light i (its own
    // distribution, or the mixture with the aim's cone where the light is aimed); 0 for other
    // lights. TwoEventMis.h weighs the VRLs leaving these lights with it.
    float directionPdf(int i, float3 dir) const;
    // The pdf (1/m^2, per unit area across dir) of the line through q along dir drawn from the disc
    // of distant light i (not the environment); 0 for other lights.
    float linePdf(int i, float3 q, float3 dir) const;
    // Where the light pass starts a line along dir through q from a distant or environment light:
    // on the plane a radius before the volumes' bounding sphere.
    float3 lineOrigin(float3 q, float3 dir) const { return q + dir * (dot(mCentre - q, dir) - mRadius); }
    // P_light: the probability that a path starts at light i (by power).
    double selectionProbability(int i) const;
    // The phase function the advanced joint distribution fits at v on a VRL leaving a light.
    NbPhase lightPhase() const { return mDefaultPhase; }

private:
    // The cone a point or spot light aims a share of its paths into (setFocus, setAimAtVolumes).
    struct AimCone {
        bool active = false;
        float3 axis;
        float cosMax = 1, oneMinusCos = 0;
    };
    AimCone aimCone(int i) const;
    static float3 ownDirection(const NbLight& l, float a, float b);
    // A point, direction and W on light i; false for a void sample. tEnd: where the first
    // segment ends (INFINITY, or the far side of a sphere light seen from inside).
    bool emit(int i, NbRng& rng, float3& x, float3& dir, float3& W, float& tEnd) const;

    const PathtraceScene* mPs;
    const VrlMedium* mMedium;
    const StopFlag* mStop;  // the render's
    int mMaxDepth;
    std::vector<double> mCdf;   // by power, normalised
    std::vector<double> mProb;  // P_light
    std::vector<char> mInward;  // sphere lights with a volume inside
    float3 mCentre;             // the volumes' bounding sphere
    float mRadius = 0;
    NbPhase mDefaultPhase;
    EmissionFocus mFocus;
    bool mAimAtVolumes = false;
};

// The share of a focused light pass's paths drawn as without a focus (LightPass::setFocus).
constexpr float kFocusDefensive = 0.2f;

}  // namespace nimbus::vrl
