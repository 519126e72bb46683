#include "JointSampling.h"

#include <algorithm>
#include <cmath>

namespace nimbus::vrl {

namespace {

// Double-precision vectors for the line geometry: the closest-point solve loses float's digits
// for nearly parallel lines.
struct D3 {
    double x, y, z;
};
D3 d3(float3 v)
{
    return {v.x, v.y, v.z};
}
D3 operator+(D3 a, D3 b)
{
    return {a.x + b.x, a.y + b.y, a.z + b.z};
}
D3 operator-(D3 a, D3 b)
{
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
D3 operator*(D3 a, double s)
{
    return {a.x * s, a.y * s, a.z * s};
}
double dotD(D3 a, D3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
D3 crossD(D3 a, D3 b)
{
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double lengthD(D3 a)
{
    return std::sqrt(dotD(a, a));
}

constexpr double kPi = 3.14159265358979323846;

// x in [0, 1) with density proportional to (1 - x) a + x b (a, b >= 0) from xi (pbrt-v4's
// SampleLinear); the inverse of the quadratic cdf, written to be stable for a ~ b.
double sampleLinear(double xi, double a, double b)
{
    if (xi == 0 && a == 0)
        return 0;
    const double x = xi * (a + b) / (a + std::sqrt(std::max(0.0, (1 - xi) * a * a + xi * b * b)));
    return std::min(x, std::nextafter(1.0, 0.0));
}

}  // namespace

// u's distribution given v: the foot of v on the camera line at u = tFoot, the (floored)
// distance hv, the arc [phiA, phiB] that the camera segment subtends, and for the advanced
// distribution the nodes phi_j with the product of the phase functions f_j and the running
// integral of the piecewise-linear fit (Oppitz eqs. 7.19-7.23).
struct JointSampler::Conditional {
    double tFoot = 0, hv = 0, phiA = 0, phiB = 0;
    int nodes = 0;
    double phi[2 * kArcIntervals + 2];
    double f[2 * kArcIntervals + 2];
    double cdf[2 * kArcIntervals + 2];  // cdf[j]: integral of the fit over [phi_0, phi_j]
};

JointSampler::JointSampler(const LinePair& lines, JointKind kind, const PhasePair& phases)
    : mL(lines), mKind(kind), mPhases(phases)
{
    const D3 dU = d3(lines.dU), dV = d3(lines.dV), w0 = d3(lines.oU) - d3(lines.oV);
    mFloor = 1e-6 * (std::fabs(lines.u1 - lines.u0) + std::fabs(lines.v1 - lines.v0)) + 1e-9;
    mSinTheta = std::min(1.0, lengthD(crossD(dU, dV)));
    const double b = dotD(dU, dV), dd = dotD(dU, w0), e = dotD(dV, w0), denom = 1 - b * b;
    double uh;
    if (mSinTheta > 1e-6 && denom > 0) {
        uh = (b * e - dd) / denom;
        mVh = e + uh * b;
    } else {
        mVh = 0;  // parallel: every v is equally far; uh is v's foot
        uh = -dd;
    }
    mH = std::max(lengthD(w0 + dU * uh - dV * mVh), mFloor);
    mA0 = std::asinh((lines.v0 - mVh) * mSinTheta / mH);
    mA1 = std::asinh((lines.v1 - mVh) * mSinTheta / mH);
    // Parallel lines, or a VRL so short against h that 1 / h(v) cannot vary across it: eq. 7.12's
    // limit is the uniform density (and its ratio of differences would cancel to noise).
    mUniformV = !(mSinTheta > 1e-6) || !(mA1 - mA0 > 1e-7);
}

double JointSampler::sampleV(float xi) const
{
    if (mUniformV)
        return mL.v0 + double(xi) * (mL.v1 - mL.v0);
    // Eq. 7.14 with v0, v1 in increasing order.
    const double v = mVh + mH * std::sinh(mA0 + double(xi) * (mA1 - mA0)) / mSinTheta;
    return std::clamp(v, mL.v0, mL.v1);
}

double JointSampler::pdfV(double v) const
{
    if (!(v >= mL.v0 && v <= mL.v1) || !(mL.v1 > mL.v0))
        return 0;
    if (mUniformV)
        return 1.0 / (mL.v1 - mL.v0);
    const double x = v - mVh;
    return mSinTheta / (std::sqrt(mH * mH + x * x * mSinTheta * mSinTheta) * (mA1 - mA0));  // eq. 7.12
}

JointSampler::Conditional JointSampler::conditional(double v) const
{
    Conditional c;
    const D3 dU = d3(mL.dU), dV = d3(mL.dV);
    const D3 p = d3(mL.oV) + dV * v;
    const D3 rel = p - d3(mL.oU);
    c.tFoot = dotD(rel, dU);
    const D3 perp = rel - dU * c.tFoot;  // from the foot to v
    const double hTrue = lengthD(perp);
    c.hv = std::max(hTrue, mFloor);
    c.phiA = std::atan((mL.u0 - c.tFoot) / c.hv);
    c.phiB = std::atan((mL.u1 - c.tFoot) / c.hv);
    if (mKind == JointKind::Simple)
        return c;

    // The arc's frame at v: n towards the foot, so v -> u(phi) = cos(phi) n + sin(phi) d_u.
    D3 n;
    if (hTrue > 1e-12) {
        n = perp * (-1.0 / hTrue);
    } else {  // v on the camera line: any normal will do for the fit
        float3 t, bb;
        nbBasis(mL.dU, &t, &bb);
        n = d3(t);
    }
    const double nv = dotD(n, dV), dv = dotD(dU, dV);
    // cos_v(phi) = cos(phi) nv + sin(phi) dv peaks at phi* = atan2(dv, nv) and has its negative
    // peak at phi* + pi (eq. 7.16: the light direction projected on the arc's plane); at most one
    // of them lies inside the arc, which spans less than pi.
    double peak = NAN;
    if (std::fabs(nv) + std::fabs(dv) > 1e-9) {
        const double margin = 1e-6 * (c.phiB - c.phiA);
        for (double cand : {std::atan2(dv, nv), std::atan2(dv, nv) + kPi, std::atan2(dv, nv) - kPi})
            if (cand > c.phiA + margin && cand < c.phiB - margin)
                peak = cand;
    }
    // Nodes: cosine-warped spacing (eq. 7.17, denser towards the ends), over [phiA, phiB] or over
    // each side of the peak (eq. 7.18), the peak itself a node.
    int count = 0;
    auto addSpan = [&](double a, double b, int intervals, bool first) {
        for (int j = first ? 0 : 1; j <= intervals; ++j)
            c.phi[count++] = a + (b - a) * 0.5 * (1 - std::cos(kPi * j / intervals));
    };
    if (std::isnan(peak)) {
        addSpan(c.phiA, c.phiB, kArcIntervals, true);
    } else {
        int left = int(std::lround(kArcIntervals * (peak - c.phiA) / (c.phiB - c.phiA)));
        left = std::clamp(left, 1, kArcIntervals - 1);
        addSpan(c.phiA, peak, left, true);
        addSpan(peak, c.phiB, kArcIntervals - left, false);
    }
    c.nodes = count;
    c.cdf[0] = 0;
    for (int j = 0; j < count; ++j) {
        // Float trigonometry: the fit only shapes the distribution (its pdf is what it is).
        const float s = std::sin(float(c.phi[j])), co = std::cos(float(c.phi[j]));
        const float cosU = -s, cosV = co * float(nv) + s * float(dv);
        c.f[j] = double(nbPhaseEval(mPhases.atU, cosU)) * double(nbPhaseEval(mPhases.atV, cosV));
        if (j > 0)
            c.cdf[j] = c.cdf[j - 1] + 0.5 * (c.f[j - 1] + c.f[j]) * (c.phi[j] - c.phi[j - 1]);  // eq. 7.23
    }
    return c;
}

double JointSampler::pdfUGivenV(double u, double v) const
{
    if (!(u >= mL.u0 && u <= mL.u1) || !(mL.u1 > mL.u0))
        return 0;
    const Conditional c = conditional(v);
    const double t = u - c.tFoot;
    const double jacobian = c.hv / (c.hv * c.hv + t * t);  // dphi / du
    if (mKind == JointKind::Simple)
        return jacobian / (c.phiB - c.phiA);  // eq. 7.7
    const double total = c.cdf[c.nodes - 1];
    const double phi = std::clamp(std::atan(t / c.hv), c.phiA, c.phiB);
    int j = int(std::upper_bound(c.phi, c.phi + c.nodes, phi) - c.phi) - 1;
    j = std::clamp(j, 0, c.nodes - 2);
    const double width = c.phi[j + 1] - c.phi[j];
    const double x = width > 0 ? (phi - c.phi[j]) / width : 0;
    const double fit = (1 - x) * c.f[j] + x * c.f[j + 1];
    return fit / total * jacobian;  // eq. 7.29
}

double JointSampler::pdf(double u, double v) const
{
    const double pv = pdfV(v);
    return pv > 0 ? pv * pdfUGivenV(u, v) : 0;
}

PairSample JointSampler::sample(float xi0, float xi1) const
{
    PairSample s;
    if (!(mL.u1 > mL.u0) || !(mL.v1 > mL.v0))
        return s;
    s.v = sampleV(xi0);
    const Conditional c = conditional(s.v);
    double phi, density;  // density: pdf in phi
    if (mKind == JointKind::Simple) {
        phi = c.phiA + double(xi1) * (c.phiB - c.phiA);  // eq. 7.8
        density = 1.0 / (c.phiB - c.phiA);
    } else {
        // The segment by the running integral, then the linear density inside it (eq. 7.26's
        // inverse, in pbrt's stable form).
        const double target = double(xi1) * c.cdf[c.nodes - 1];
        int j = int(std::upper_bound(c.cdf, c.cdf + c.nodes, target) - c.cdf) - 1;
        j = std::clamp(j, 0, c.nodes - 2);
        const double seg = c.cdf[j + 1] - c.cdf[j];
        const double xi = seg > 0 ? std::clamp((target - c.cdf[j]) / seg, 0.0, 1.0) : 0.5;
        const double x = sampleLinear(xi, c.f[j], c.f[j + 1]);
        phi = c.phi[j] + x * (c.phi[j + 1] - c.phi[j]);
        density = ((1 - x) * c.f[j] + x * c.f[j + 1]) / c.cdf[c.nodes - 1];
    }
    s.u = std::clamp(c.tFoot + c.hv * std::tan(phi), mL.u0, mL.u1);
    const double t = s.u - c.tFoot;
    s.pdf = pdfV(s.v) * density * c.hv / (c.hv * c.hv + t * t);
    return s;
}

}  // namespace nimbus::vrl
