// SphericalHarmonics.h: real, orthonormal spherical harmonics y_jm for the light volumes of area,
// environment and emission sources (Tessendorf eqs. 85-87).
//
// Index jm -> j*j + j + m (m = -j..j); (J+1)^2 functions up to order J. Polar axis +z, azimuth
// from +x toward +y. Normalisation int y_jm y_j'm' dOmega = delta; the real basis relates to
// Boost's complex Y_j^m (Condon-Shortley phase included) by
//   y_j0 = Y_j^0,  y_jm = sqrt(2) (-1)^m Re Y_j^m,  y_j,-m = sqrt(2) (-1)^m Im Y_j^m   (m > 0),
// which tests/wkb checks. The m-sum of eq. 88 is basis independent:
// sum_m y_jm(n) y_jm(n') = (2j+1)/(4 pi) P_j(n . n') (the addition theorem).
// Written as a recurrence: Boost's per-(j,m) calls are exact but too slow per camera ray.
#pragma once

#include "../core/Vec.h"

#include <cmath>

namespace nimbus::wkb {

inline int shCount(int order)
{
    return (order + 1) * (order + 1);
}
inline int shIndex(int j, int m)
{
    return j * j + j + m;
}

// Writes y_jm(dir) for j = 0..order into out[shCount(order)]; dir unit length. order <= 16.
inline void shEvaluate(int order, float3 dir, double* out)
{
    const double z = std::fmax(-1.0, std::fmin(1.0, double(dir.z)));
    const double rxy = std::sqrt(std::fmax(0.0, 1.0 - z * z));
    // cos(m phi), sin(m phi) by the angle-addition recurrence (phi undefined at the poles: 0).
    double c1 = 1.0, s1 = 0.0;
    if (rxy > 1e-12) {
        c1 = double(dir.x) / rxy;
        s1 = double(dir.y) / rxy;
    }
    double cm[17], sm[17];
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
        double pPrev = 0.0, p = pmm;
        for (int j = m; j <= order; ++j) {
            if (j == m + 1) {
                pPrev = p;
                p = z * double(2 * m + 1) * pmm;
            } else if (j > m + 1) {
                double next = (double(2 * j - 1) * z * p - double(j + m - 1) * pPrev) / double(j - m);
                pPrev = p;
                p = next;
            }
            // K_jm = sqrt((2j+1)/(4 pi) (j-m)!/(j+m)!)
            double ratio = 1.0;
            for (int k = j - m + 1; k <= j + m; ++k)
                ratio /= double(k);
            double K = std::sqrt(double(2 * j + 1) * NB_INV_4PI_D * ratio);
            if (m == 0) {
                out[shIndex(j, 0)] = K * p;
            } else {
                out[shIndex(j, m)] = std::sqrt(2.0) * K * p * cm[m];
                out[shIndex(j, -m)] = std::sqrt(2.0) * K * p * sm[m];
            }
        }
    }
}

}  // namespace nimbus::wkb
