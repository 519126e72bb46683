#include "AngularKernel.h"

#include "../../kernels/shared/compat.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nimbus::wkb {

double gaussianMu(double p1)
{
    if (!(p1 > std::exp(-kMuMax)))
        return kMuMax;
    return std::min(kMuMax, std::max(kMuMin, -std::log(p1)));
}

double lOverOneMinusExp(double l)
{
    if (!(l > 0.0))
        return 1.0;
    return l / -std::expm1(-l);
}

double gaussianA(int j, double mu, double l)
{
    return std::exp(-0.5 * muL(mu, l) * double(j) * double(j + 1));
}

double exactRatio(double p, double l)
{
    if (!(l > 0.0))
        return p;
    if (l <= 1.0)
        return std::expm1(l * p) / std::expm1(l);
    // (e^{lp} - 1)/(e^l - 1) = e^{l(p-1)} (1 - e^{-lp}) / (1 - e^{-l}) for p > 0, and
    // (e^{lp} - 1) e^{-l} / (1 - e^{-l}) for p <= 0: every factor is at most 1 in magnitude.
    double denom = -std::expm1(-l);
    if (p > 0.0)
        return std::exp(l * (p - 1.0)) * -std::expm1(-l * p) / denom;
    return std::expm1(l * p) * std::exp(-l) / denom;
}

double weight(double l, double omega0)
{
    if (!(omega0 > 0.0) || !(l > 0.0))
        return 0.0;
    double alpha = 1.0 / omega0 - 1.0;  // absorption per scattering length, >= 0
    return std::exp(-l * alpha) * -std::expm1(-l);
}

double gaussianFactor(int j, double mu, double l, double omega0)
{
    return weight(l, omega0) * gaussianA(j, mu, l);
}

double exactFactor(double p, double l, double omega0)
{
    if (!(omega0 > 0.0) || !(l > 0.0))
        return 0.0;
    if (p > 0.0)  // e^{-l(1/omega0 - p)} (1 - e^{-lp}), both factors in [0, 1]
        return std::exp(-l * (1.0 / omega0 - p)) * -std::expm1(-l * p);
    return std::exp(-l / omega0) * std::expm1(l * p);
}

double weightIntegral(double la, double tauA, double dl, double omega0)
{
    if (!(dl > 0.0) || !(omega0 > 0.0))
        return 0.0;
    const double alpha = 1.0 / omega0 - 1.0;
    const double x = dl / omega0;  // optical depth of the step
    // int_0^dl e^{-alpha u} du and int_0^dl e^{-u/omega0} du:
    const double A = alpha > 0.0 ? -std::expm1(-alpha * dl) / alpha : dl;
    const double B = omega0 * -std::expm1(-x);
    // A - B = int_0^dl e^{-alpha u}(1 - e^{-u}) du >= 0. The closed form loses ~eps * 2/x relative
    // accuracy; below x = 1e-3 use its alternating series
    // sum_{n>=1} (-1)^{n+1} ((alpha+1)^n - alpha^n) dl^{n+1} / (n+1)!  (6 terms: error < x^6 / 5040).
    double AminusB;
    if (x < 1e-3) {
        AminusB = 0.0;
        double a1 = alpha + 1.0, pa1 = 1.0, pa = 1.0, pdl = dl, fact = 1.0, sign = 1.0;
        for (int n = 1; n <= 6; ++n) {
            pa1 *= a1;
            pa *= alpha;
            pdl *= dl;
            fact *= double(n + 1);
            AminusB += sign * (pa1 - pa) * pdl / fact;
            sign = -sign;
        }
    } else {
        AminusB = A - B;
    }
    AminusB = std::max(0.0, AminusB);
    // e^{-tauA} [A - e^{-la} B] = e^{-tauA} [(A - B) + (1 - e^{-la}) B]: no cancellation left.
    return std::exp(-tauA) * (AminusB + -std::expm1(-la) * B);
}

double remainingWeightBound(double la, double tauA, double omegaMax)
{
    (void)la;
    if (!(omegaMax < 1.0))
        return std::numeric_limits<double>::infinity();
    // int_0^inf e^{-tauA} e^{-alpha u} (1 - e^{-la - u}) du <= e^{-tauA} / alpha with alpha >= 1/omegaMax - 1.
    return std::exp(-tauA) / (1.0 / omegaMax - 1.0);
}

Truncation truncateOrders(KernelType k, double l, double mu, double gmax, double tolerance, int orderCap)
{
    Truncation t;
    const double tolAbs = std::max(tolerance, 0.0) * NB_INV_4PI_D;
    gmax = std::min(std::fabs(gmax), 1.0);
    const double q = std::exp(-muL(mu, l));  // A_{j+1} / A_j = q^{j+1}
    // term(j) bounds (2j+1)/(4pi) |p_j R_j(l)|; ratio(j) bounds term(i+1)/term(i) for all i >= j.
    double gpow = 1.0, A = 1.0, qpow = 1.0;  // gmax^j, A_j, q^j
    auto ratioFrom = [&](int j) {
        double odd = double(2 * j + 3) / double(2 * j + 1);
        return k == KernelType::Gaussian ? odd * gmax * qpow * q : odd * gmax * gmax;
    };
    double sum = NB_INV_4PI_D;  // j = 0: p_0 R_0 = 1
    orderCap = std::max(orderCap, 0);
    for (int j = 0;; ++j) {
        // term j+1
        double gnext = gpow * gmax;
        double Rnext;
        if (k == KernelType::Gaussian) {
            qpow *= q;  // q^{j+1}
            A *= qpow;  // A_{j+1}
            Rnext = A;
        } else {
            Rnext = exactRatio(gnext, l);
        }
        double next = double(2 * j + 3) * NB_INV_4PI_D * gnext * Rnext;
        double r = ratioFrom(j + 1);
        double tail = next <= 0.0 ? 0.0 : (r < 1.0 ? next / (1.0 - r) : std::numeric_limits<double>::infinity());
        if (tail <= tolAbs || j >= orderCap) {
            t.order = j;
            t.tailBound = tail;
            t.capped = tail > tolAbs;
            t.total = sum + tail;
            return t;
        }
        sum += next;
        gpow = gnext;
    }
}

}  // namespace nimbus::wkb
