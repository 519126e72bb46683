// The recurrences the WKB march keeps for speed against Boost.Math, over every order the renderer
// allows: LegendreSeries (the delta-source order sum, j <= render.wkb_order_max <= 4096) against
// boost::math::legendre_p, and shEvaluate (SH light volumes, j <= kShOrderMax = 16, of which
// render.wkb_sh_order_max allows 8) against boost::math::spherical_harmonic_r / _i. References in
// long double (64-bit mantissa: their own error is 2^-11 of the tolerances below, neglected).
#include "wkb/LegendreSeries.h"
#include "render/SphericalHarmonics.h"

#include <boost/math/special_functions/legendre.hpp>
#include <boost/math/special_functions/spherical_harmonic.hpp>
#include <gtest/gtest.h>

#include <array>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace nimbus;
using namespace nimbus::wkb;

namespace {

constexpr int kOrderMax = 4096;  // SceneValidate: render.wkb_order_max in [0, 4096] (default 128)
constexpr double kEps = DBL_EPSILON;

// Arguments x = cos: both endpoints, 0, Chebyshev points across the interval, and points within
// a few ulp to 1e-2 of +-1, where the recurrence's error grows fastest.
std::vector<double> legendreArguments()
{
    std::vector<double> xs = {-1.0, 1.0, 0.0, -0.5, 0.5};
    for (int i = 1; i <= 8; ++i)
        xs.push_back(std::cos(M_PI * (i - 0.5) / 8));
    for (double d : {0x1p-53, 1e-12, 1e-8, 1e-4, 1e-2}) {
        xs.push_back(1.0 - d);
        xs.push_back(-1.0 + d);
    }
    return xs;
}

}  // namespace

// P_j(x) from the series against boost::math::legendre_p<long double>, every j <= 4096.
//
// Tolerance: one step ((2j+1) x P_j - j P_{j-1}) / (j+1) with |P| <= 1 rounds to at most
// 9 eps (products of size <= 2 and <= 1, their difference, the division). An error d made at step
// k reaches order j as d G(j, k), G solving the same recurrence; G is a combination of P_j and
// Q_j (Legendre has no dominant solution on [-1, 1]), so |G(j, k)| <= j - k + 1 (its growth at
// x = +-1, where the second solution is the harmonic number H_j) and, by Bernstein's inequality
// |P_j|, |Q_j| <= sqrt(2 / (pi j sin theta)), |G| <= 4 / (pi sin theta). Summed over k <= j:
//     |error_j| <= 9 eps (j + 1) min((j + 1) / 2, 4 / (pi sin theta)).
TEST(WkbLegendre, SeriesMatchesBoostLegendreP)
{
    double worst = 0.0, worstAbs = 0.0;
    for (double x : legendreArguments()) {
        const double sinTheta = std::sqrt((1.0 - x) * (1.0 + x));
        LegendreSeries P(x);
        for (int j = 0; j <= kOrderMax; ++j, P.advance()) {
            ASSERT_EQ(P.order(), j);
            const long double ref = boost::math::legendre_p(j, (long double)x);
            const double growth = sinTheta > 0.0 ? std::fmin(0.5 * (j + 1), 4.0 / (M_PI * sinTheta)) : 0.5 * (j + 1);
            const double tol = 9.0 * kEps * (j + 1) * growth;
            const double err = double(std::fabs((long double)P.value() - ref));
            worst = std::fmax(worst, err / tol);
            worstAbs = std::fmax(worstAbs, err);
            ASSERT_LE(err, tol) << "j=" << j << " x=" << x;
        }
    }
    std::printf("LegendreSeries, j <= %d: max |error| %.2e, max error / tolerance %.3f\n", kOrderMax, worstAbs, worst);
    RecordProperty("max_abs_error", std::to_string(worstAbs));
}

// Real SH against Boost's complex Y_j^m. Boost's legendre_p(j, m, x) carries the Condon-Shortley
// phase, P_j^m = (-1)^m (1 - x^2)^{m/2} d^m P_j / dx^m, and Y_j^m = K_jm P_j^m(cos theta) e^{i m phi}
// with K_jm = sqrt((2j+1)/(4 pi) (j-m)!/(j+m)!). shEvaluate's P_j^m lacks the phase, so with
// m > 0 and the real basis y_jm = sqrt(2) K_jm P_j^m cos(m phi), y_j,-m = sqrt(2) K_jm P_j^m sin(m phi):
//     y_j0 = Y_j^0,   y_jm = sqrt(2) (-1)^m Re Y_j^m,   y_j,-m = sqrt(2) (-1)^m Im Y_j^m.
// (Boost's spherical_harmonic_r(j, m, ...) is Re Y_j^m, _i is Im Y_j^m.) The direction is read as
// shEvaluate reads it: theta = acos(z), phi = atan2(y, x), both in long double from the float
// components.
//
// Tolerance, relative to |y_jm| <= sqrt(2 (2j+1)/(4 pi)): K_jm <= 3 eps (Boost's gamma ratio and
// a square root), P_m^m <= 3 (m + 1) eps (sin theta from (1-z)(1+z), one rounding per factor),
// the upward recurrence in j <= 3 (j - m) eps (stable for P_j^m from P_m^m, as above but with
// j <= 16 its growth stays under 3), cos and sin of m phi by angle addition <= 2 m eps:
// all within 8 (j + 1) eps.
TEST(WkbSh, RealBasisMatchesBoostOverEveryOrder)
{
    std::vector<float3> dirs = {make_float3(0, 0, 1),
                                make_float3(0, 0, -1),
                                make_float3(1, 0, 0),
                                make_float3(0, 1, 0),
                                make_float3(-1, 0, 0),
                                make_float3(0, -1, 0),
                                make_float3(1, 1, 0) * float(M_SQRT1_2)};
    for (int s = 0; s < 300; ++s) {
        const double z = 1.0 - 2.0 * std::fmod(s * 0.618034, 1.0), phi = 2 * M_PI * std::fmod(s * 0.75488, 1.0);
        const double r = std::sqrt(1.0 - z * z);
        dirs.push_back(normalize(make_float3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z))));
    }
    for (float t : {1e-7f, 1e-5f, 1e-3f}) {  // near the poles
        dirs.push_back(normalize(make_float3(t, 0.3f * t, 1.0f)));
        dirs.push_back(normalize(make_float3(-t, 0.7f * t, -1.0f)));
    }
    const int J = kShOrderMax;
    std::vector<double> y(size_t(shCount(J)));
    double worst = 0.0, worstAbs = 0.0;
    for (float3 d : dirs) {
        shEvaluate(J, d, y.data());
        const long double theta = std::acos((long double)d.z), phi = std::atan2((long double)d.y, (long double)d.x);
        for (int j = 0; j <= J; ++j) {
            const double tol = 8.0 * kEps * (j + 1) * std::sqrt(2.0 * (2 * j + 1) / (4.0 * M_PI));
            for (int m = -j; m <= j; ++m) {
                const unsigned am = unsigned(std::abs(m));
                const long double sign = am % 2 ? -1.0L : 1.0L, sqrt2 = std::sqrt(2.0L);
                long double ref;
                if (m == 0)
                    ref = boost::math::spherical_harmonic_r(unsigned(j), 0, theta, phi);
                else if (m > 0)
                    ref = sqrt2 * sign * boost::math::spherical_harmonic_r(unsigned(j), int(am), theta, phi);
                else
                    ref = sqrt2 * sign * boost::math::spherical_harmonic_i(unsigned(j), int(am), theta, phi);
                const double err = double(std::fabs((long double)y[size_t(shIndex(j, m))] - ref));
                worst = std::fmax(worst, err / tol);
                worstAbs = std::fmax(worstAbs, err);
                ASSERT_LE(err, tol) << "j=" << j << " m=" << m << " dir " << d.x << " " << d.y << " " << d.z;
            }
        }
    }
    std::printf("shEvaluate, j <= %d: max |error| %.2e, max error / tolerance %.3f\n", J, worstAbs, worst);
    RecordProperty("max_abs_error", std::to_string(worstAbs));
}

// The addition theorem that closes the m-sum for delta-direction sources:
// sum_m y_jm(n) y_jm(n') = (2j+1)/(4 pi) P_j(n . n'), against boost::math::legendre_p, with n and
// n' the unit directions shEvaluate reads from the float vectors (polar angle from z, azimuth from
// x and y). Tolerance: 2j + 1 products of two values each within the previous test's tolerance
// of a bound sqrt(2 (2j+1)/(4 pi)): 2 (2j+1) 8 (j+1) eps 2 (2j+1)/(4 pi), plus the reference.
TEST(WkbSh, AdditionTheoremClosesTheMSum)
{
    const int J = kShOrderMax;
    std::vector<double> y(size_t(shCount(J))), y2(size_t(shCount(J)));
    auto unit = [](float3 d) {  // the direction shEvaluate evaluates
        long double z = d.z, s = std::sqrt((1.0L - z) * (1.0L + z)), x = d.x, yy = d.y, r = std::hypot(x, yy);
        return r > 0 ? std::array<long double, 3>{s * x / r, s * yy / r, z} : std::array<long double, 3>{0, 0, z};
    };
    double worst = 0.0;
    for (int s = 0; s < 100; ++s) {
        const double theta = std::acos(1.0 - 2.0 * std::fmod(s * 0.618034, 1.0)),
                     phi = 2 * M_PI * std::fmod(s * 0.75488, 1.0);
        const float3 n = make_float3(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                                     float(std::cos(theta)));
        const float3 n2 = s == 0 ? n : normalize(make_float3(0.3f, -0.8f, float(s) / 50.0f - 1.0f));
        shEvaluate(J, n, y.data());
        shEvaluate(J, n2, y2.data());
        const auto a = unit(n), b = unit(n2);
        const long double cosine = std::fmax(-1.0L, std::fmin(1.0L, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]));
        for (int j = 0; j <= J; ++j) {
            double sum = 0.0;
            for (int m = -j; m <= j; ++m)
                sum += y[size_t(shIndex(j, m))] * y2[size_t(shIndex(j, m))];
            const long double ref = (2 * j + 1) / (4 * M_PI) * boost::math::legendre_p(j, cosine);
            const double tol = 2.0 * (2 * j + 1) * 8.0 * kEps * (j + 1) * 2.0 * (2 * j + 1) / (4.0 * M_PI);
            const double err = double(std::fabs((long double)sum - ref));
            worst = std::fmax(worst, err / tol);
            ASSERT_LE(err, tol) << "j=" << j << " s=" << s;
        }
    }
    std::printf("addition theorem, j <= %d: max error / tolerance %.3f\n", J, worst);
}
