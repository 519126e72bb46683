// Phase functions (kernels/shared/phase.h): normalisation, mean cosine, Legendre moments and a
// chi-square test of the sampler against the evaluator (STYLE rule 13).
#include "../../kernels/shared/phase.h"
#include "../../kernels/shared/rng.h"

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <boost/math/special_functions/legendre.hpp>
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <vector>

namespace {

// Integral over the sphere of f(cos) dOmega = 2 pi int_{-1}^{1} f(mu) dmu, by Boost.Math's adaptive
// Gauss-Kronrod on each hemisphere with mu = +-(1 - t^2), which concentrates nodes at mu = +-1
// where strong forward and backward peaks live. The integrands evaluate the phase function in
// float: the relative error target is a few float ulp (8 FLT_EPSILON, 1e-6), below which the
// adaptive error estimate is rounding noise.
template <class F>
double sphereIntegral(F f)
{
    double sum = 0;
    for (double side : {1.0, -1.0})
        sum += boost::math::quadrature::gauss_kronrod<double, 61>::integrate(
            [&](double t) { return f(side * (1.0 - t * t)) * 2.0 * t; }, 0.0, 1.0, 15, 8 * FLT_EPSILON);
    return 2.0 * M_PI * sum;
}

NbPhase hg(float g)
{
    return NbPhase{g, 0, 0, 0};
}

}  // namespace

class PhaseG : public ::testing::TestWithParam<float> {};

TEST_P(PhaseG, NormalisedWithMeanCosineG)
{
    float g = GetParam();
    NbPhase p = hg(g);
    double norm = sphereIntegral([&](double mu) { return nbPhaseEval(p, float(mu)); });
    double mean = sphereIntegral([&](double mu) { return mu * nbPhaseEval(p, float(mu)); });
    EXPECT_NEAR(norm, 1.0, 2e-4) << "g=" << g;
    EXPECT_NEAR(mean, g, 2e-4) << "g=" << g;
}

TEST_P(PhaseG, LegendreMomentsAreGToTheJ)
{
    float g = GetParam();
    NbPhase p = hg(g);
    nb_moment pj[7] = {0, 0, 0, 0, 0, 0, 0};
    nbPhaseAddMoments(p, 1.0, 6, pj);
    for (int j = 0; j <= 6; ++j) {
        double m =
            sphereIntegral([&](double mu) { return boost::math::legendre_p(j, mu) * nbPhaseEval(p, float(mu)); });
        EXPECT_NEAR(m, pj[j], 5e-4) << "g=" << g << " j=" << j;
    }
}

// Chi-square: histogram of sampled cosines against the expected counts from the evaluator.
TEST_P(PhaseG, SamplerMatchesEvaluatorChiSquare)
{
    float g = GetParam();
    NbPhase p = NbPhase{g, -0.3f, 0.25f, 0};  // two-lobe mixture exercises lobe selection too
    const int bins = 64, samples = 400000;
    std::vector<double> observed(bins, 0.0), expected(bins, 0.0);
    float3 wi = normalize(make_float3(0.3f, -0.5f, 0.8f));
    const double side = g < 0 ? -1.0 : 1.0;
    for (int s = 0; s < samples; ++s) {
        NbRng r = nbRngStart(7u, 0u, nb_uint(s));
        float u0 = nbRngNext(&r), u1 = nbRngNext(&r), u2 = nbRngNext(&r);
        float3 wo = nbPhaseSample(p, wi, u0, u1, u2);
        ASSERT_NEAR(length(wo), 1.0f, 1e-4f);
        // Bin by t in [0,1) where side*mu = 1 - 2 t^2 (dense near the peak of lobe g).
        double mu = side * std::min(1.0, std::max(-1.0, double(dot(wo, wi))));
        int b = std::min(bins - 1, int(std::sqrt((1.0 - mu) / 2.0) * bins));
        observed[b] += 1;
    }
    for (int b = 0; b < bins; ++b) {
        double t0 = double(b) / bins, t1 = double(b + 1) / bins;
        double mu0 = 1 - 2 * t1 * t1, mu1 = 1 - 2 * t0 * t0;
        // int_{mu0}^{mu1} 2 pi p(mu) dmu
        const double integral = boost::math::quadrature::gauss_kronrod<double, 61>::integrate(
            [&](double mu) { return 2 * M_PI * nbPhaseEval(p, float(side * mu)); }, mu0, mu1, 10, 8 * FLT_EPSILON);
        expected[b] = integral * samples;
    }
    // Pool bins with small expectations (Cochran's rule) before the statistic.
    double chi2 = 0, pooledO = 0, pooledE = 0;
    int dof = -1;
    for (int b = 0; b < bins; ++b) {
        pooledO += observed[b];
        pooledE += expected[b];
        if (pooledE >= 5) {
            chi2 += (pooledO - pooledE) * (pooledO - pooledE) / pooledE;
            pooledO = pooledE = 0;
            ++dof;
        }
    }
    boost::math::chi_squared dist(dof);
    double pValue = 1.0 - boost::math::cdf(dist, chi2);
    EXPECT_GT(pValue, 1e-3) << "g=" << g << " chi2=" << chi2 << " dof=" << dof;
}

INSTANTIATE_TEST_SUITE_P(Hg, PhaseG, ::testing::Values(-0.99f, -0.5f, 0.0f, 0.5f, 0.9f, 0.99f));

TEST(Phase, TwoLobeIsMixture)
{
    NbPhase p{0.8f, -0.4f, 0.3f, 0};
    for (float mu : {-1.0f, -0.2f, 0.0f, 0.7f, 1.0f})
        EXPECT_NEAR(nbPhaseEval(p, mu), 0.7f * nbHgEval(0.8f, mu) + 0.3f * nbHgEval(-0.4f, mu), 1e-6f);
    EXPECT_NEAR(nbPhaseMeanCos(p), 0.7f * 0.8f - 0.3f * 0.4f, 1e-6f);
    // The moments by running powers, against the closed form in double (g, g2 and w as floats).
    nb_moment pj[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    nbPhaseAddMoments(p, 2.0, 8, pj);
    for (int j = 0; j <= 8; ++j)
        EXPECT_NEAR(
            pj[j], 2.0 * ((1.0 - double(0.3f)) * std::pow(double(0.8f), j) + double(0.3f) * std::pow(double(-0.4f), j)),
            1e-14)
            << j;
    EXPECT_EQ(nbPhaseMomentBound(p), double(0.8f));
    // Every order the WKB march may sum (render.wkb_order_max <= 4096), against long double
    // powers. Each running power rounds once per order, the sum of the two lobes once more:
    // |error_j| <= (j + 2) eps (|a_j| + |b_j|), a_j, b_j the lobes' terms; past j ~ 3200 0.8^j is
    // below double's normal range, where each rounding adds at most half the smallest denormal.
    const int J = 4096;
    std::vector<nb_moment> moments(size_t(J) + 1, 0.0);
    nbPhaseAddMoments(p, 1.0, J, moments.data());
    for (int j = 0; j <= J; ++j) {
        const long double a = (1.0L - double(0.3f)) * std::pow((long double)double(0.8f), j),
                          b = double(0.3f) * std::pow((long double)double(-0.4f), j);
        const double tol = (j + 2) * DBL_EPSILON * double(std::fabs(a) + std::fabs(b)) + (j + 2) * DBL_TRUE_MIN;
        ASSERT_LE(double(std::fabs(moments[size_t(j)] - (a + b))), tol) << j;
    }
    EXPECT_EQ(nbPhaseMomentBound(NbPhase{0.2f, -0.9f, 0.0f, 0}), double(0.2f));  // one lobe: g2 unused
}
