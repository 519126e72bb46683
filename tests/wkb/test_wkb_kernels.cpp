// The l-dependent pieces of L2+ (src/wkb/AngularKernel, ScatteringTable, SourcePlacement) against
// direct evaluation: long double closed forms, Boost.Math quadrature and brute-force sums (issue 3
// "How it is checked", unit tests). The Legendre and SH recurrences: test_wkb_legendre.cpp.
#include "wkb/AngularKernel.h"
#include "wkb/ScatteringTable.h"
#include "wkb/SourcePlacement.h"

#include <boost/math/quadrature/gauss.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace nimbus;
using namespace nimbus::wkb;

namespace {

const double kLs[] = {1e-6, 1e-4, 1e-2, 0.125, 1.0, 7.5, 100.0, 1e3, 1e4};
const double kOmegas[] = {1.0, 0.999, 0.9, 0.5, 0.05};

// Relative agreement of two values given as logarithms of their magnitudes: |ratio - 1| to first
// order. Values below double's range compare through their logarithms, so that the test covers
// l = 1e4 with albedo 0.05 (factors of e^{-190000}), where ours is exactly 0.
void expectRelative(double ours, long double logRef, int sign, double tol, const char* what, double l, double x)
{
    if (sign == 0) {
        EXPECT_EQ(ours, 0.0) << what << " l=" << l << " x=" << x;
        return;
    }
    ASSERT_TRUE(std::isfinite(ours)) << what << " l=" << l << " x=" << x;
    if (logRef < -700.0L) {  // below the smallest normal double: 0 or a denormal is right
        EXPECT_LE(std::fabs(ours), 1e-300) << what << " l=" << l << " x=" << x;
        return;
    }
    ASSERT_EQ(ours > 0 ? 1 : -1, sign) << what << " l=" << l << " x=" << x;
    const long double logOurs = std::log(std::fabs((long double)ours));
    EXPECT_NEAR(double(logOurs - logRef), 0.0, tol) << what << " l=" << l << " x=" << x;
}

}  // namespace

// e^{-l/omega0}(e^l - 1) A_j(l) in its stable form against the naive long double product,
// l = 1e-6 .. 1e4: relative error below 1e-11 everywhere, no overflow, no 0/0.
TEST(WkbKernel, GaussianFactorMatchesDirectEvaluation)
{
    for (double l : kLs)
        for (double omega : kOmegas)
            for (double mu : {1e-3, 0.1, 2.0})
                for (int j : {0, 1, 3, 10}) {
                    const long double L = l, w = omega;
                    const long double muL = mu * L / (-std::expm1(-L));
                    const long double logRef = -L / w + std::log(std::expm1(L)) - muL * j * (j + 1) / 2.0L;
                    expectRelative(gaussianFactor(j, mu, l, omega), logRef, 1, 1e-11, "gaussian", l, omega);
                }
}

// e^{-l/omega0}(e^{l p} - 1) for p from -0.99 to 1, same range and accuracy.
TEST(WkbKernel, ExactFactorMatchesDirectEvaluation)
{
    for (double l : kLs)
        for (double omega : kOmegas)
            for (double p : {-0.99, -0.5, 0.0, 1e-8, 0.3, 0.9, 0.99, 1.0}) {
                const long double L = l, w = omega, P = p;
                const long double e = std::expm1(L * P);
                const int sign = p == 0.0 ? 0 : (p > 0 ? 1 : -1);
                const long double logRef = -L / w + std::log(std::fabs(e));
                expectRelative(exactFactor(p, l, omega), logRef, sign, 1e-11, "exact", l, p);
                // The ratio used per march node, (e^{lp} - 1)/(e^l - 1), from the same reference.
                const long double logRatio = std::log(std::fabs(e)) - std::log(std::expm1(L));
                expectRelative(exactRatio(p, l), logRatio, sign, 1e-11, "ratio", l, p);
            }
}

TEST(WkbKernel, BothKernelsAgreeAtOrderZeroAndOneForSmallL)
{
    // R_0 = 1 for both; at l -> 0 both reduce to one extra scattering: R_1 -> p_1 = e^{-mu}.
    for (double g : {0.2, 0.5, 0.9, 0.99}) {
        const double mu = gaussianMu(g);
        EXPECT_DOUBLE_EQ(gaussianA(0, mu, 1e-6), 1.0);
        EXPECT_DOUBLE_EQ(exactRatio(1.0, 1e-6), 1.0);
        EXPECT_NEAR(gaussianA(1, mu, 1e-6), g, 1e-6);
        EXPECT_NEAR(exactRatio(g, 1e-6), g, 1e-6);
    }
}

// The weight integrated over a march step against Gauss-Legendre quadrature of the naive
// integrand in long double (30 nodes on each of 64 dyadic pieces [dl 2^-k-1, dl 2^-k], so that
// both the l^2/2 start and a fast e^{-u/omega0} decay are resolved): relative error below 1e-9,
// from steps of 1e-7 to 1e3 scattering lengths, at l up to 1e4.
TEST(WkbKernel, WeightIntegralMatchesQuadrature)
{
    using boost::math::quadrature::gauss;
    for (double la : {0.0, 1e-6, 0.5, 30.0, 1e4})
        for (double dl : {1e-7, 1e-3, 0.25, 5.0, 1e3})
            for (double omega : {1.0, 0.999, 0.5, 0.01})
                for (double tauA : {0.0, 3.0}) {
                    const long double w = omega, a = la, tA = tauA;
                    auto f = [&](long double u) {
                        long double l = a + u, tau = tA + a + u / w;
                        return std::exp(-tau) * std::expm1(l);
                    };
                    long double ref = 0.0L, hi = dl;
                    for (int k = 0; k < 64; ++k, hi *= 0.5L)
                        ref += gauss<long double, 30>::integrate(f, 0.5L * hi, hi);
                    double ours = weightIntegral(la, tauA, dl, omega);
                    ASSERT_TRUE(std::isfinite(ours));
                    ASSERT_GE(ours, 0.0);
                    if (ref < 1e-290L) {
                        EXPECT_LE(ours, 1e-280) << la << " " << dl << " " << omega;
                        continue;
                    }
                    EXPECT_NEAR(double(ours / ref), 1.0, 1e-9)
                        << "la=" << la << " dl=" << dl << " omega=" << omega << " tauA=" << tauA;
                }
}

TEST(WkbKernel, RemainingWeightBoundsTheTail)
{
    for (double la : {0.0, 2.0, 50.0})
        for (double omega : {0.5, 0.9, 0.999}) {
            double tail = weightIntegral(la, 0.7, 1e7, omega);
            double bound = remainingWeightBound(la, 0.7, omega);
            EXPECT_LE(tail, bound * (1 + 1e-12));
            EXPECT_GE(tail, 0.3 * bound);  // and not vacuous: within a small factor for large la
        }
    EXPECT_TRUE(std::isinf(remainingWeightBound(1.0, 0.0, 1.0)));
}

// The truncation order J bounds the neglected terms: brute-force sums of
// (2j+1)/(4pi) |p_j R_j(l)| over j > J (to j = 20000) stay under both the reported tail bound and
// tolerance / (4pi), for HG g in {-0.99 .. 0.99}, both kernels, l from 1e-6 to 1e4; and J - 1 would
// not have been provably enough.
TEST(WkbKernel, TruncationBoundHolds)
{
    const double tol = 1e-3, inv4pi = 1.0 / (4.0 * M_PI);
    for (KernelType k : {KernelType::Gaussian, KernelType::Exact})
        for (double g : {-0.99, -0.5, 0.0, 0.5, 0.9, 0.99})
            for (double l : {1e-6, 0.125, 1.0, 10.0, 1e3, 1e4}) {
                const double mu = gaussianMu(g);
                Truncation t = truncateOrders(k, l, mu, std::fabs(g), tol, 5000);
                ASSERT_FALSE(t.capped) << "g=" << g << " l=" << l;
                double tail = 0.0, gp = 1.0;
                for (int j = 1; j <= 20000; ++j) {
                    gp *= g;
                    if (j <= t.order)
                        continue;
                    double R = k == KernelType::Gaussian ? gaussianA(j, mu, l) : exactRatio(gp, l);
                    tail += (2 * j + 1) * inv4pi * std::fabs(gp * R);
                }
                EXPECT_LE(tail, t.tailBound * (1 + 1e-9) + 1e-300) << "g=" << g << " l=" << l;
                EXPECT_LE(t.tailBound, tol * inv4pi) << "g=" << g << " l=" << l;
                if (t.order > 0) {
                    Truncation shorter = truncateOrders(k, l, mu, std::fabs(g), tol, t.order - 1);
                    EXPECT_TRUE(shorter.capped) << "g=" << g << " l=" << l;
                }
            }
    // A cap is reported as such.
    Truncation capped = truncateOrders(KernelType::Exact, 1e-3, gaussianMu(0.99), 0.99, 1e-3, 16);
    EXPECT_TRUE(capped.capped);
    EXPECT_EQ(capped.order, 16);
}

// The (l, s) table inverted against exact values in a homogeneous medium.
TEST(WkbTable, HomogeneousInversionIsExact)
{
    ScatteringTable t;
    t.reset(2.0);  // the medium starts 2 m from the camera
    const double b[3] = {0.5, 1.0, 3.0}, a[3] = {0.1, 0.0, 0.2};
    const double bhat = (0.5 + 1.0 + 3.0) / 3.0;
    for (int i = 0; i < 40; ++i)
        t.append(0.05 + 0.01 * (i % 3), b, a);  // uneven stretches, same coefficients
    for (double l : {0.0, 1e-9, 0.3, 1.7, 2.9}) {
        double s = t.sAt(l);
        EXPECT_NEAR(s, 2.0 + l / bhat, 1e-12);
        TableEntry e = t.at(s);
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(e.l[c], b[c] * (s - 2.0), 1e-12);
            EXPECT_NEAR(e.tauA[c], a[c] * (s - 2.0), 1e-12);
        }
        // 6 P = l s'^2 with s' measured from where the medium starts (eq. 79's s^2 l).
        const double sp = s - 2.0;
        EXPECT_NEAR(6.0 * e.P, bhat * sp * sp * sp, 1e-10);
    }
}

// Piecewise constant: [0,1] b = 1, gap [1,2], [2,2.5] b = 10, [2.5,4] b = 0.1 (grey).
TEST(WkbTable, PiecewiseConstantInversionIsExact)
{
    ScatteringTable t;
    t.reset(0.0);
    auto grey = [](double v) { return std::vector<double>{v, v, v}; };
    const double zero[3] = {0, 0, 0};
    struct Piece {
        double len, b;
    };
    const Piece pieces[] = {{1.0, 1.0}, {1.0, 0.0}, {0.5, 10.0}, {1.5, 0.1}};
    for (const Piece& p : pieces) {
        // Split each piece in uneven stretches, as the march does.
        std::vector<double> bb = grey(p.b);
        t.append(0.3 * p.len, bb.data(), zero);
        t.append(0.7 * p.len, bb.data(), zero);
    }
    auto lOf = [](double s) {
        if (s <= 1.0)
            return s;
        if (s <= 2.0)
            return 1.0;
        if (s <= 2.5)
            return 1.0 + 10.0 * (s - 2.0);
        return 6.0 + 0.1 * (s - 2.5);
    };
    auto sOf = [](double l) {  // the first s reaching l
        if (l <= 1.0)
            return l;
        if (l <= 6.0)
            return 2.0 + (l - 1.0) / 10.0;
        return 2.5 + (l - 6.0) / 0.1;
    };
    for (double l : {0.25, 1.0, 1.0 + 1e-9, 3.3, 6.0, 6.1}) {
        EXPECT_NEAR(t.sAt(l), sOf(l), 1e-12) << l;
    }
    // P(s) = int_0^s l(s') (s - s') ds': a quadratic between the pieces' ends, so 7-point
    // Gauss-Legendre on each is exact (to rounding).
    for (double s : {0.5, 1.5, 2.25, 3.9}) {
        TableEntry e = t.at(s);
        EXPECT_NEAR(e.lhat, lOf(s), 1e-12);
        auto f = [&](double sp) { return lOf(sp) * (s - sp); };
        double P = 0.0, lo = 0.0;
        for (double hi : {1.0, 2.0, 2.5, 4.0}) {
            if (lo < s)
                P += boost::math::quadrature::gauss<double, 7>::integrate(f, lo, std::min(hi, s));
            lo = hi;
        }
        EXPECT_NEAR(e.P, P, 1e-12 * std::max(1.0, P)) << s;
    }
}

TEST(WkbPlacement, StraightLineBlurIsEq79)
{
    // Homogeneous medium entered at the camera: sigma = W / sqrt(12), W = s sqrt(K mu l).
    ScatteringTable t;
    t.reset(0.0);
    const double b[3] = {2, 2, 2}, a[3] = {0, 0, 0};
    for (int i = 0; i < 100; ++i)
        t.append(0.01, b, a);
    PlacementInput in;
    in.table = &t;
    in.at = t.at(0.6);
    in.mu = 0.1;
    in.blurK = 24.0;
    SourceRead r = placeSource(PlacementModel::Straight, in);
    const double l = 1.2, s = 0.6;
    EXPECT_NEAR(r.s, s, 1e-12);
    EXPECT_NEAR(r.sigma, s * std::sqrt(24.0 * 0.1 * l) / std::sqrt(12.0), 1e-9);
}

TEST(WkbPlacement, RandomWalkMomentsAndLimits)
{
    // g -> 1: a straight path (mean displacement l, no spread); l -> inf: the transport length.
    EXPECT_NEAR(walkMeanDisplacement(3.0, 1.0), 3.0, 1e-12);
    EXPECT_NEAR(walkVariance(3.0, 1.0), 0.0, 1e-12);
    EXPECT_NEAR(walkMeanDisplacement(1e4, 0.9), 10.0, 1e-9);
    // Isotropic walk of many steps: <R^2> = 2 l (in mean free paths^2), variance -> 2 l - 3.
    EXPECT_NEAR(walkVariance(1e4, 0.0) / (2e4 - 3.0), 1.0, 1e-9);
    // The small-x series joins the closed form continuously.
    for (double g : {0.5, 0.9, 0.99})
        for (double l : {0.999e-3 / (1 - g), 1.001e-3 / (1 - g)}) {
            long double k = 1.0L - g, x = k * l, E = -std::expm1(-x);
            long double ref = (2 * (x - E) - E * E) / (k * k);
            EXPECT_NEAR(walkVariance(l, g) / double(ref), 1.0, 1e-6) << g << " " << l;
        }
    // Placement: the source sits at the mean displacement, found in the table.
    ScatteringTable t;
    t.reset(0.0);
    const double b[3] = {4, 4, 4}, a[3] = {0, 0, 0};
    for (int i = 0; i < 100; ++i)
        t.append(0.05, b, a);
    PlacementInput in;
    in.table = &t;
    in.at = t.at(2.5);  // l = 10
    in.g = 0.8;
    SourceRead r = placeSource(PlacementModel::RandomWalk, in);
    EXPECT_NEAR(r.s, walkMeanDisplacement(10.0, 0.8) / 4.0, 1e-12);
    EXPECT_NEAR(r.sigma, std::sqrt(walkVariance(10.0, 0.8) / 3.0) / 4.0, 1e-12);
}
