// SlabSolver.h: an independent, deterministic solution of radiative transfer in a homogeneous
// plane-parallel slab with isotropic scattering under collimated light incident at cosine mu0
// (normal incidence by default), to validate the path tracer's multiple scattering. It
// reproduces the published table of van de Hulst (1980), "Multiple Light Scattering", vol. 1,
// Table 12, to its printed five decimals (test_pathtrace_slab_published.cpp), and the test
// reports the discretisation error it measures (two resolutions) and checks flux conservation
// for albedo 1.
//
// Method: the source function S(tau) (radiance units) of the diffuse field obeys the
// Schwarzschild-Milne integral equation (Chandrasekhar 1960, "Radiative Transfer", sec. 11;
// van de Hulst 1980, ch. 3)
//     S(tau) = (a E / 4 pi) e^{-tau / mu0} + (a / 2) int_0^tau0 E1(|tau - tau'|) S(tau') dtau',
// E the irradiance of the beam on a surface facing it, a the single-scattering albedo, E1 the
// exponential integral. Isotropic scattering makes S independent of direction, so the field is
// azimuthally symmetric at any incidence. Nystrom-style collocation: S constant on N equal
// cells, the E1 kernel integrated exactly over each cell (int E1 = -E2), which handles its
// logarithmic singularity. The matrix I - K is symmetric (Toeplitz) and positive definite for
// a <= 1, so conjugate gradients solve it in a few dozen iterations even for thick conservative
// slabs, where Gauss-Seidel would need thousands. Emerging radiance at cosine mu from the normal:
//     I_top(mu)    = int S(tau) e^{-tau/mu} dtau / mu          (reflected, upward)
//     I_bottom(mu) = int S(tau) e^{-(tau0 - tau)/mu} dtau / mu (diffusely transmitted)
// both integrated exactly over the piecewise-constant S.
#pragma once

#include <boost/math/quadrature/gauss.hpp>
#include <boost/math/special_functions/expint.hpp>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace nimbus::pttest {

// E_n(x) = int_1^inf e^{-x t} t^{-n} dt, Boost.Math's; E2(0) = 1.
inline double expint1(double x)
{
    return boost::math::expint(1, x);
}
inline double expint2(double x)
{
    return x <= 0 ? 1.0 : boost::math::expint(2, x);
}

class SlabSolver {
public:
    // Solves for unit beam irradiance E = 1 (on a surface facing the beam), incident at cosine
    // mu0 from the normal of the lit face. maxOrder > 0 keeps only light scattered at most
    // that many times (a path tracer's max_depth): the Neumann series S = sum_{k < maxOrder}
    // K^k s0, term k being the source of light scattered k + 1 times.
    SlabSolver(double tau0, double albedo, int cells, double mu0 = 1.0, int maxOrder = 0)
        : mTau0(tau0), mA(albedo), mMu0(mu0), mN(cells)
    {
        const double h = tau0 / cells;
        mH = h;
        // Toeplitz kernel: k[d] = (a/2) int over a cell at distance d cells of E1.
        std::vector<double> k(static_cast<size_t>(cells));
        k[0] = albedo * (1 - expint2(0.5 * h));
        for (int d = 1; d < cells; ++d)
            k[size_t(d)] = 0.5 * albedo * (expint2((d - 0.5) * h) - expint2((d + 0.5) * h));
        std::vector<double> s0(static_cast<size_t>(cells));
        for (int i = 0; i < cells; ++i) {
            // Cell average of the single-scattering source e^{-tau/mu0}.
            double lo = i * h, hi = lo + h;
            s0[size_t(i)] = albedo / (4 * M_PI) * mu0 * (std::exp(-lo / mu0) - std::exp(-hi / mu0)) / h;
        }
        // Conjugate gradients on (I - K) S = s0.
        auto apply = [&](const std::vector<double>& x, std::vector<double>& y) {
            for (int i = 0; i < cells; ++i) {
                double v = x[size_t(i)];
                for (int j = 0; j < cells; ++j)
                    v -= k[size_t(std::abs(i - j))] * x[size_t(j)];
                y[size_t(i)] = v;
            }
        };
        if (maxOrder > 0) {
            mS = s0;
            std::vector<double> term = s0, next(static_cast<size_t>(cells));
            for (int order = 2; order <= maxOrder; ++order) {
                for (int i = 0; i < cells; ++i) {
                    double v = 0;
                    for (int j = 0; j < cells; ++j)
                        v += k[size_t(std::abs(i - j))] * term[size_t(j)];
                    next[size_t(i)] = v;
                }
                term.swap(next);
                for (int i = 0; i < cells; ++i)
                    mS[size_t(i)] += term[size_t(i)];
            }
            return;
        }
        mS.assign(size_t(cells), 0.0);
        std::vector<double> r = s0, p = s0, Ap(static_cast<size_t>(cells));
        double rr = 0;
        for (double v : r)
            rr += v * v;
        const double stop = 1e-28 * rr;
        for (int iter = 0; iter < 2 * cells && rr > stop; ++iter) {
            apply(p, Ap);
            double pAp = 0;
            for (int i = 0; i < cells; ++i)
                pAp += p[size_t(i)] * Ap[size_t(i)];
            const double alpha = rr / pAp;
            double rrNew = 0;
            for (int i = 0; i < cells; ++i) {
                mS[size_t(i)] += alpha * p[size_t(i)];
                r[size_t(i)] -= alpha * Ap[size_t(i)];
                rrNew += r[size_t(i)] * r[size_t(i)];
            }
            for (int i = 0; i < cells; ++i)
                p[size_t(i)] = r[size_t(i)] + rrNew / rr * p[size_t(i)];
            rr = rrNew;
        }
    }

    // Reflected radiance leaving the lit face at cosine mu, per unit beam irradiance.
    double top(double mu) const
    {
        double sum = 0;
        for (int j = 0; j < mN; ++j)
            sum += mS[size_t(j)] * (std::exp(-j * mH / mu) - std::exp(-(j + 1) * mH / mu));
        return sum;
    }
    // Diffusely transmitted radiance leaving the far face at cosine mu.
    double bottom(double mu) const
    {
        double sum = 0;
        for (int j = 0; j < mN; ++j)
            sum += mS[size_t(j)] * (std::exp(-(mTau0 - (j + 1) * mH) / mu) - std::exp(-(mTau0 - j * mH) / mu));
        return sum;
    }
    // Hemispherical fluxes over the incident one (mu0 E): R = 2 pi int_0^1 I_top(mu) mu dmu / mu0,
    // likewise T (diffuse part; the direct beam adds e^{-tau0/mu0}).
    double reflectance() const { return flux(true) / mMu0; }
    double diffuseTransmittance() const { return flux(false) / mMu0; }

private:
    double flux(bool up) const;

    double mTau0, mA, mMu0, mH = 0;
    int mN;
    std::vector<double> mS;
};

// Gauss-Legendre nodes (ascending) and weights on [0, 1]: Boost.Math's n-point rule on [-1, 1]
// (boost::math::quadrature::gauss, which stores the non-negative half), mapped. For the n the
// slab tests use; another n is a logic error in the test.
template <unsigned N>
void gaussLegendre01(std::vector<double>& x, std::vector<double>& w)
{
    using G = boost::math::quadrature::gauss<double, N>;
    const auto &t = G::abscissa(), &g = G::weights();
    x.clear();
    w.clear();
    for (size_t i = t.size(); i-- > 0;) {  // the negative nodes, -t[i], ascending
        if (t[i] == 0.0)
            continue;  // odd N: the middle node, once, below
        x.push_back(0.5 * (1.0 - t[i]));
        w.push_back(0.5 * g[i]);
    }
    for (size_t i = 0; i < t.size(); ++i) {
        x.push_back(0.5 * (1.0 + t[i]));
        w.push_back(0.5 * g[i]);
    }
}

inline void gaussLegendre01(int n, std::vector<double>& x, std::vector<double>& w)
{
    switch (n) {
    case 8: return gaussLegendre01<8>(x, w);
    case 12: return gaussLegendre01<12>(x, w);
    case 16: return gaussLegendre01<16>(x, w);
    default: throw std::logic_error("gaussLegendre01: no " + std::to_string(n) + "-point rule instantiated");
    }
}

// R or T: 2 pi int_0^1 I(mu) mu dmu, 64-point Gauss-Legendre on each of 16 pieces (the
// radiance varies fastest near grazing mu, where e^{-tau/mu} turns on).
inline double SlabSolver::flux(bool up) const
{
    const int pieces = 16;
    double sum = 0;
    for (int p = 0; p < pieces; ++p)
        sum += boost::math::quadrature::gauss<double, 64>::integrate(
            [&](double mu) { return (up ? top(mu) : bottom(mu)) * mu; }, double(p) / pieces, double(p + 1) / pieces);
    return 2 * M_PI * sum;
}

}  // namespace nimbus::pttest
