// JointSampling.h: the joint distributions of a point pair (u on a camera ray, v on a virtual
// ray light) for the volume-to-volume transport of virtual ray lights (Novak et al. 2012,
// "Virtual ray lights for rendering scenes with participating media", sec. 5; Oppitz 2018,
// sec. 7.3). The integrand of Oppitz eq. 7.3 varies most through 1 / w(u, v)^2, w the distance
// between the points, and, in anisotropic media, through the two phase functions; both
// distributions draw v first from a marginal and then u from a conditional given v:
//
//  - Simple (Oppitz 7.3.1): v with pdf proportional to 1 / h(v), h(v) the distance from v to the
//    camera ray's line: the marginal of 1 / w^2 over an infinite camera ray (eq. 7.12), sampled by
//    its inverse cdf (eqs. 7.13-7.14, sinh / asinh); then u equi-angularly towards v (Kulla and
//    Fajardo 2012; Oppitz eqs. 7.7-7.8), pdf proportional to 1 / w^2 on the camera segment.
//  - Advanced (Oppitz 7.3.2): the same v; then u in the angle phi subtended at v (u = u_v + h_v
//    tan phi, so 1 / w^2 du = dphi / h_v) from a piecewise-linear fit of the product of the two
//    Henyey-Greenstein phase functions f_u f_v along the arc (eqs. 7.19-7.26), its nodes
//    cosine-warped towards the ends of the arc with one on the peak of f_v where the peak (or the
//    negative peak) lies on the arc (eqs. 7.16-7.18); the pdf in u is pdf_phi(phi) h_v / (h_v^2 +
//    t^2) (eq. 7.29).
//
// Both are exact pdfs of what they sample (the estimator divides by them), so any smoothing of the
// distributions only changes the noise, never the expectation: distances h below a floor (lines
// that cross) use the floor in both the sampling and the pdf, so the pdf stays finite.
//
// Geometry: the camera ray o_u + u d_u and the VRL o_v + v d_v, d_u and d_v unit, world space,
// metres; u in [u0, u1] and v in [v0, v1], both segments of finite length.
#pragma once

#include "../../kernels/shared/compat.h"
#include "../../kernels/shared/phase.h"

namespace nimbus::vrl {

enum class JointKind { Simple, Advanced };

struct LinePair {
    float3 oU, dU;  // camera ray
    double u0 = 0, u1 = 0;
    float3 oV, dV;  // virtual ray light
    double v0 = 0, v1 = 0;
};

// What the advanced distribution fits along the arc: the phase function at u (its argument the
// cosine between the light's travel direction v -> u and the direction towards the camera, -d_u)
// and at v (between d_v and v -> u). Ignored by the simple distribution.
struct PhasePair {
    NbPhase atU{0, 0, 0, 0};
    NbPhase atV{0, 0, 0, 0};
};

struct PairSample {
    double u = 0, v = 0;
    double pdf = 0;  // joint pdf in (u, v), 1/m^2; 0: no sample (an empty segment)
};

// The advanced distribution's nodes along the arc (intervals; nodes = intervals + 1).
constexpr int kArcIntervals = 16;

class JointSampler {
public:
    JointSampler(const LinePair& lines, JointKind kind, const PhasePair& phases = {});

    // One pair from two uniform numbers in [0, 1).
    PairSample sample(float xi0, float xi1) const;
    // The joint pdf of the pair (u, v), 0 outside the segments.
    double pdf(double u, double v) const;

    // The two factors, for tests: the marginal of v and the conditional of u given v.
    double pdfV(double v) const;
    double pdfUGivenV(double u, double v) const;

private:
    struct Conditional;  // u's distribution given v: foot, distance, arc, nodes
    Conditional conditional(double v) const;
    double sampleV(float xi) const;

    LinePair mL;
    JointKind mKind;
    PhasePair mPhases;
    double mSinTheta = 0;     // sine of the angle between the lines
    double mVh = 0;           // where on the VRL the lines come closest (v parameter)
    double mH = 0;            // their distance there (floored)
    double mA0 = 0, mA1 = 0;  // A(v0 - vh), A(v1 - vh): eq. 7.12's asinh terms
    bool mUniformV = false;   // (nearly) parallel lines: 1 / h(v) is flat; v uniform
    double mFloor = 0;        // the smallest distance the distributions resolve, metres
};

}  // namespace nimbus::vrl
