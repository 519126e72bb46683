// SphericalHarmonics.h: real, orthonormal spherical harmonics y_jm for the light volumes of area,
// environment and emission sources (Tessendorf eqs. 85-87).
//
// Index jm -> j*j + j + m (m = -j..j); (J+1)^2 functions up to order J. Polar axis +z, azimuth
// from +x toward +y. Normalisation int y_jm y_j'm' dOmega = delta; the real basis relates to
// Boost's complex Y_j^m (Condon-Shortley phase included) by
//   y_j0 = Y_j^0,  y_jm = sqrt(2) (-1)^m Re Y_j^m,  y_j,-m = sqrt(2) (-1)^m Im Y_j^m   (m > 0),
// which tests/wkb/test_wkb_legendre.cpp checks for every order here, poles included. The m-sum of
// eq. 88 is basis independent: sum_m y_jm(n) y_jm(n') = (2j+1)/(4 pi) P_j(n . n') (the addition
// theorem).
//
// Written as recurrences (P_m^m, then boost::math::legendre_next upward in j; cos and sin of m phi
// by angle addition): boost::math::spherical_harmonic_r per (j, m) restarts the Legendre recurrence
// and calls cos, sin and a gamma ratio each time, too slow per camera ray and per light sample of
// every light voxel. The normalisations K_jm are Boost's, computed once.
#pragma once

#include "../core/Vec.h"

#include <boost/math/special_functions/gamma.hpp>
#include <boost/math/special_functions/legendre.hpp>

#include <cmath>

namespace nimbus {

inline int shCount(int order)
{
    return (order + 1) * (order + 1);
}
inline int shIndex(int j, int m)
{
    return j * j + j + m;
}

constexpr int kShOrderMax = 16;  // shEvaluate's limit (render.wkb_sh_order_max allows 8)

// K_jm = sqrt((2j+1)/(4 pi) (j-m)!/(j+m)!) for 0 <= m <= j <= kShOrderMax, the ratio of
// factorials as boost::math::spherical_harmonic takes it (tgamma_delta_ratio).
struct ShNormalisation {
    double K[kShOrderMax + 1][kShOrderMax + 1] = {};
    ShNormalisation()
    {
        for (int j = 0; j <= kShOrderMax; ++j)
            for (int m = 0; m <= j; ++m)
                K[j][m] = std::sqrt(double(2 * j + 1) * NB_INV_4PI_D *
                                    boost::math::tgamma_delta_ratio(double(j - m + 1), double(2 * m)));
    }
};
inline const ShNormalisation& shNormalisation()
{
    static const ShNormalisation n;
    return n;
}

// Writes y_jm(dir) for j = 0..order into out[shCount(order)]; dir unit length, order <= kShOrderMax.
// The polar angle is read from dir.z, the azimuth from (dir.x, dir.y) alone: a float direction a
// few ulp off unit length still gives cos^2 + sin^2 = 1 for the azimuth.
inline void shEvaluate(int order, float3 dir, double* out)
{
    const double(&K)[kShOrderMax + 1][kShOrderMax + 1] = shNormalisation().K;
    const double z = std::fmax(-1.0, std::fmin(1.0, double(dir.z)));
    const double rxy = std::sqrt(std::fmax(0.0, (1.0 - z) * (1.0 + z)));  // sin theta; no cancellation at the poles
    // cos(m phi), sin(m phi) by the angle-addition recurrence (phi undefined at the poles: 0).
    const double x = double(dir.x), y = double(dir.y), r = std::sqrt(x * x + y * y);
    double c1 = 1.0, s1 = 0.0;
    if (r > 0.0) {
        c1 = x / r;
        s1 = y / r;
    }
    double cm[kShOrderMax + 1], sm[kShOrderMax + 1];
    cm[0] = 1.0, sm[0] = 0.0;
    for (int m = 1; m <= order; ++m) {
        cm[m] = cm[m - 1] * c1 - sm[m - 1] * s1;
        sm[m] = sm[m - 1] * c1 + cm[m - 1] * s1;
    }
    // Associated Legendre P_j^m(z) without the Condon-Shortley phase, for each m upward in j.
    double pmm = 1.0;  // P_m^m = (2m-1)!! (1 - z^2)^{m/2}
    for (int m = 0; m <= order; ++m) {
        if (m > 0)
            pmm *= double(2 * m - 1) * rxy;
        double pPrev = 0.0, p = pmm;  // P_{j-1}^m, P_j^m; P_{m-1}^m = 0 makes the first step exact
        for (int j = m; j <= order; ++j) {
            if (j > m) {
                const double next = boost::math::legendre_next(unsigned(j - 1), unsigned(m), z, p, pPrev);
                pPrev = p;
                p = next;
            }
            if (m == 0) {
                out[shIndex(j, 0)] = K[j][0] * p;
            } else {
                out[shIndex(j, m)] = std::sqrt(2.0) * K[j][m] * p * cm[m];
                out[shIndex(j, -m)] = std::sqrt(2.0) * K[j][m] * p * sm[m];
            }
        }
    }
}

}  // namespace nimbus
