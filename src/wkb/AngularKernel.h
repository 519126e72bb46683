// AngularKernel.h: the l-dependent factors of Tessendorf's L2+ (eqs. 62-64, 70, 85-89), in
// forms that neither overflow nor divide 0 by 0 for l from 0 to 1e4 and beyond.
//
// Notation (docs/notation.md, docs/wkb.md): l = int b ds is the scattering length along the
// camera ray (dimensionless), tau = int c ds the optical depth, tau_a = tau - l the absorption
// depth, omega0 = b / c the albedo, p_j the Legendre moments of the phase function
// (int P_j(cos) P dOmega = p_j, p_0 = 1; HG: p_j = g^j), mu the squared angular width of the
// phase function's forward peak (eq. 61).
//
// L2+ = int_0^inf dl T(0,s)(e^l - 1) sum_j K_j(l) p_j sum_m Y_jm(n) Lblur^jm     (eq. 88)
//
// where T(0,s)(e^l - 1) = e^{-tau}(e^l - 1) = e^{-tau_a} - e^{-tau}, the "weight" w(l), and the
// angular kernel relative to it, R_j(l), is
//   Gaussian phase (eqs. 63-64, 70):  R_j = A_j(l) = exp(-mu_l j(j+1)/2), mu_l = mu l/(1 - e^-l)
//   exact, infinite homogeneous medium: R_j = (e^{l p_j} - 1)/(e^l - 1)
// The exact form counts the Poisson number N >= 1 of scatterings after the first (which is the
// explicit p_j of eq. 88): sum_N e^{-l} l^N/N! p_j^N = e^{-l}(e^{l p_j} - 1). Tessendorf's form is
// its Gaussian-phase approximation (eq. 62). Both give R_0 = 1.
//
// Everything here is double: the march state accumulates thousands of steps, and the weight
// integral is a difference of nearly equal terms at small steps (handled by a series there).
#pragma once

namespace nimbus::wkb {

enum class KernelType { Gaussian, Exact };

// The phase function's Legendre moments p_j are kernels/shared/phase.h's (nbPhaseAddMoments,
// nbPhaseMeanCos, nbPhaseMomentBound), in double on the host.

// Bounds on mu: below p_1 = e^{-kMuMax} the phase function has no forward peak for the Gaussian
// model to describe (isotropic or backward); the clamp keeps the blur width finite. kMuMin keeps
// g -> 1 (a delta forward peak) from dividing by zero in the order estimate.
constexpr double kMuMin = 1e-4;
constexpr double kMuMax = 2.0;

// mu from the first moment by matching the Gaussian phase's own p_1 = e^{-mu} (eq. 70 with one
// scattering: A_1 = e^{-mu}), so both kernels agree at order 1 for small l: mu = -ln p_1.
double gaussianMu(double p1);

// l / (1 - e^{-l}) without 0/0 at l -> 0 (-> 1) or overflow at large l (-> l).
double lOverOneMinusExp(double l);

// mu_l = mu l / (1 - e^-l), eq. 64.
inline double muL(double mu, double l)
{
    return mu * lOverOneMinusExp(l);
}

// A_j(l) = exp(-mu_l j (j+1) / 2), eq. 63/70.
double gaussianA(int j, double mu, double l);

// (e^{l p} - 1)/(e^l - 1) for l >= 0, |p| <= 1: -> p at l -> 0, no overflow at l = 1e4.
double exactRatio(double p, double l);

// The weight with constant albedo: e^{-l/omega0}(e^l - 1) = e^{-l(1/omega0 - 1)} - e^{-l/omega0},
// the second form as DESIGN.md prescribes, computed as e^{-l(1/omega0 - 1)} (1 - e^{-l}).
double weight(double l, double omega0);

// The full per-order factors (weight times R_j): what the unit tests compare with direct
// evaluation. gaussianFactor = e^{-l/omega0}(e^l - 1) A_j(l); exactFactor = e^{-l/omega0}(e^{l p} - 1).
double gaussianFactor(int j, double mu, double l, double omega0);
double exactFactor(double p, double l, double omega0);

// The weight integrated over one step of the march, l in [la, la + dl], along which the albedo
// omega0 is constant: int e^{-tau(l)}(e^l - 1) dl with tau(la) = tauA + la (tauA the absorption
// depth at la) and d tau = dl / omega0. Exact; non-negative; series where the closed form cancels.
double weightIntegral(double la, double tauA, double dl, double omega0);

// The weight integrated from la to infinity when omega0 < 1 stays below omegaMax: an upper bound
// of what the rest of a march can add (per unit source and angular factor), +inf for omegaMax = 1.
double remainingWeightBound(double la, double tauA, double omegaMax);

// The angular kernel R_j(l) for one kernel type.
inline double kernelRatio(KernelType k, int j, double pj, double mu, double l)
{
    return k == KernelType::Gaussian ? gaussianA(j, mu, l) : exactRatio(pj, l);
}

// Where to stop the order sum: the smallest J such that the bound on the terms j > J of
//     sum_j (2j+1)/(4 pi) |p_j| |R_j(l)| |P_j(cos)|     (the delta-source sum; |P_j| <= 1)
// is at most tolerance / (4 pi) (the size of the j = 0 term), and that bound. With |p_j| <=
// gmax^j: Gaussian terms t_j = (2j+1)/(4pi) gmax^j A_j, whose ratio t_{j+1}/t_j decreases in j;
// exact terms t_j = (2j+1)/(4pi) gmax^j R(l, gmax^j), whose ratio is at most (2j+3)/(2j+1) gmax^2
// (convexity: e^{a x} - 1 <= a (e^x - 1) for a in [0,1]). Once the ratio r < 1 the tail after J
// is at most t_{J+1}/(1 - r). `orderCap` caps J; then `tailBound` may exceed the tolerance and
// `capped` is set. `total` bounds the whole sum (used for the march's stopping test).
struct Truncation {
    int order = 0;
    double tailBound = 0.0;
    double total = 0.0;
    bool capped = false;
};
Truncation truncateOrders(KernelType k, double l, double mu, double gmax, double tolerance, int orderCap);

}  // namespace nimbus::wkb
