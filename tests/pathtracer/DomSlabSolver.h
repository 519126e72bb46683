// DomSlabSolver.h: discrete ordinates for a homogeneous plane-parallel slab with Henyey-
// Greenstein scattering under a normally incident beam, independent of SlabSolver.h (which
// handles isotropic scattering only); at g = 0 the two must agree, which tests both.
//
// Normal incidence makes the field azimuthally symmetric, so only the azimuthal mean (m = 0)
// of the phase function acts, exactly:
//     mu dI/dtau = -I + S,   S(tau, mu) = a E e^{-tau} p(mu)                      (first scattering
//                                                                                of the beam, exact HG)
//                  + a sum_l (2l+1)/(4 pi) g^l P_l(mu) 2 pi int_{-1}^{1} P_l(mu') I(tau, mu') dmu'
// with tau from the lit face, mu > 0 downward (Chandrasekhar 1960 ch. 1; Thomas & Stamnes 1999,
// "Radiative Transfer in the Atmosphere and Ocean", ch. 6 and 8). Double-Gauss quadrature
// (Sykes 1951): Gauss-Legendre on each hemisphere, n nodes each, Legendre terms to 2n - 1 (nodes,
// weights and P_l from Boost.Math).
// Along each ordinate the transfer equation is integrated exactly for a source linear in tau
// between grid nodes; source iteration to convergence. The emerging radiance in any direction
// comes from integrating the converged source function (with the exact HG for the beam term)
// along that direction, so it is not tied to the quadrature nodes.
#pragma once

#include "SlabSolver.h"

#include <boost/math/quadrature/gauss.hpp>
#include <boost/math/special_functions/legendre.hpp>

#include <cmath>
#include <vector>

namespace nimbus::pttest {

class DomSlabSolver {
public:
    DomSlabSolver(double tau0, double albedo, double g, int nodesPerHemisphere, int cells)
        : mTau0(tau0), mA(albedo), mG(g), mCells(cells)
    {
        std::vector<double> x, w;
        gaussLegendre01(nodesPerHemisphere, x, w);
        for (int i = 0; i < nodesPerHemisphere; ++i) {  // down (mu > 0), then up (mu < 0)
            mMu.push_back(x[size_t(i)]);
            mW.push_back(w[size_t(i)]);
        }
        for (int i = 0; i < nodesPerHemisphere; ++i) {
            mMu.push_back(-x[size_t(i)]);
            mW.push_back(w[size_t(i)]);
        }
        mL = 2 * nodesPerHemisphere;  // Legendre orders 0 .. 2n - 1
        const size_t M = mMu.size(), K = size_t(cells) + 1;
        std::vector<std::vector<double>> P(M, std::vector<double>(size_t(mL)));
        for (size_t i = 0; i < M; ++i)
            legendre(mMu[i], P[i]);
        // I[i][k]: radiance along ordinate i at node k (tau_k = k h).
        std::vector<std::vector<double>> I(M, std::vector<double>(K, 0.0)), S(M, std::vector<double>(K, 0.0));
        mMoments.assign(K, std::vector<double>(size_t(mL), 0.0));
        const double h = tau0 / cells;
        for (int iter = 0; iter < 5000; ++iter) {
            // Source from the current moments.
            for (size_t k = 0; k < K; ++k) {
                double beam = mA * std::exp(-double(k) * h);
                for (size_t i = 0; i < M; ++i)
                    S[i][k] = beam * hg(mMu[i]) + diffuseSource(mMoments[k], P[i]);
            }
            // Sweep every ordinate.
            for (size_t i = 0; i < M; ++i) {
                const double delta = h / std::fabs(mMu[i]), e = std::exp(-delta);
                const double a0 = 1 - e, a1 = 1 - (1 - e) / delta;
                if (mMu[i] > 0) {
                    I[i][0] = 0;
                    for (size_t k = 1; k < K; ++k)
                        I[i][k] = I[i][k - 1] * e + S[i][k - 1] * a0 + (S[i][k] - S[i][k - 1]) * a1;
                } else {
                    I[i][K - 1] = 0;
                    for (size_t k = K - 1; k-- > 0;)
                        I[i][k] = I[i][k + 1] * e + S[i][k + 1] * a0 + (S[i][k] - S[i][k + 1]) * a1;
                }
            }
            // New moments 2 pi int P_l I dmu, and the change.
            double change = 0;
            for (size_t k = 0; k < K; ++k)
                for (int l = 0; l < mL; ++l) {
                    double m = 0;
                    for (size_t i = 0; i < M; ++i)
                        m += mW[i] * P[i][size_t(l)] * I[i][k];
                    m *= 2 * M_PI;
                    change = std::max(change, std::fabs(m - mMoments[k][size_t(l)]));
                    mMoments[k][size_t(l)] = m;
                }
            if (change < 1e-13)
                break;
        }
    }

    // Reflected radiance leaving the lit face at cosine mu (per unit beam irradiance).
    double top(double mu) const { return emerging(-mu); }
    // Diffusely transmitted radiance leaving the far face at cosine mu.
    double bottom(double mu) const { return emerging(mu); }
    double reflectance() const { return flux(true); }
    double diffuseTransmittance() const { return flux(false); }

private:
    double hg(double cosTheta) const
    {
        double d = 1 + mG * mG - 2 * mG * cosTheta;
        return (1 - mG * mG) / (4 * M_PI * d * std::sqrt(d));
    }
    void legendre(double mu, std::vector<double>& p) const
    {
        for (int l = 0; l < mL; ++l)
            p[size_t(l)] = boost::math::legendre_p(l, mu);
    }
    double diffuseSource(const std::vector<double>& moments, const std::vector<double>& P) const
    {
        double s = 0, gl = 1;
        for (int l = 0; l < mL; ++l, gl *= mG)
            s += (2 * l + 1) / (4 * M_PI) * gl * P[size_t(l)] * moments[size_t(l)];
        return mA * s;
    }
    // Radiance leaving the slab along direction mu (> 0: through the bottom, < 0: the top),
    // integrating the source function exactly for linear variation between nodes.
    double emerging(double mu) const
    {
        std::vector<double> P(static_cast<size_t>(mL));
        legendre(mu, P);
        const double h = mTau0 / mCells, delta = h / std::fabs(mu), e = std::exp(-delta);
        const double a0 = 1 - e, a1 = 1 - (1 - e) / delta;
        auto source = [&](int k) { return mA * std::exp(-k * h) * hg(mu) + diffuseSource(mMoments[size_t(k)], P); };
        double I = 0;
        if (mu > 0) {
            for (int k = 1; k <= mCells; ++k)
                I = I * e + source(k - 1) * a0 + (source(k) - source(k - 1)) * a1;
        } else {
            for (int k = mCells - 1; k >= 0; --k)
                I = I * e + source(k + 1) * a0 + (source(k) - source(k + 1)) * a1;
        }
        return I;
    }
    // 2 pi int_0^1 I(mu) mu dmu, 32-point Gauss-Legendre on each of 8 pieces.
    double flux(bool up) const
    {
        const int pieces = 8;
        double sum = 0;
        for (int p = 0; p < pieces; ++p)
            sum += boost::math::quadrature::gauss<double, 32>::integrate(
                [&](double mu) { return (up ? top(mu) : bottom(mu)) * mu; }, double(p) / pieces,
                double(p + 1) / pieces);
        return 2 * M_PI * sum;
    }

    double mTau0, mA, mG;
    int mCells, mL = 0;
    std::vector<double> mMu, mW;
    std::vector<std::vector<double>> mMoments;  // per tau node, 2 pi int P_l I dmu
};

}  // namespace nimbus::pttest
