// Pixel filters (kernels/shared/filter.h): each profile integrates to 1, its CDF is its
// integral, the sampler inverts the CDF, and a chi-square test holds the sampler against the
// profile (STYLE rule 13).
#include "../../kernels/shared/filter.h"
#include "../../kernels/shared/rng.h"

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <boost/math/special_functions/erf.hpp>
#include <gtest/gtest.h>

#include <vector>

namespace {

struct Case {
    int type;
    float width;
    const char* name;
};

const Case kCases[] = {{NB_FILTER_BOX, 1.0f, "box 1"},
                       {NB_FILTER_BOX, 2.5f, "box 2.5"},
                       {NB_FILTER_GAUSSIAN, 2.0f, "gaussian 2"},
                       {NB_FILTER_GAUSSIAN, 4.5f, "gaussian 4.5"},
                       {NB_FILTER_BLACKMAN_HARRIS, 3.0f, "blackman_harris 3"},
                       {NB_FILTER_BLACKMAN_HARRIS, 1.5f, "blackman_harris 1.5"}};

double integral(const Case& c, double a, double b)
{
    auto f = [&](double x) { return double(nbFilterEval(c.type, c.width, float(x))); };
    return boost::math::quadrature::gauss_kronrod<double, 61>::integrate(f, a, b, 10, 1e-12);
}

}  // namespace

TEST(PixelFilter, ProfilesIntegrateToOneAndVanishOutside)
{
    for (const Case& c : kCases) {
        const double r = 0.5 * c.width;
        EXPECT_NEAR(integral(c, -r, r), 1.0, 2e-6) << c.name;
        EXPECT_EQ(nbFilterEval(c.type, c.width, float(r) * 1.001f), 0.0f) << c.name;
        EXPECT_GE(nbFilterEval(c.type, c.width, float(r) * 0.999f), 0.0f) << c.name;  // never negative
    }
}

TEST(PixelFilter, CdfIsTheProfilesIntegral)
{
    for (const Case& c : kCases) {
        const double r = 0.5 * c.width;
        for (double x = -r; x <= r; x += r / 16.0)
            EXPECT_NEAR(nbFilterCdf(c.type, c.width, float(x)), integral(c, -r, x), 3e-6) << c.name << " at " << x;
    }
}

TEST(PixelFilter, SampleInvertsTheCdf)
{
    double worst = 0;
    for (const Case& c : kCases)
        for (int i = 0; i <= 4096; ++i) {
            const float u = std::min(float(i) / 4096.0f, 0.99999994f);
            const float x = nbFilterSample(c.type, c.width, u);
            ASSERT_LE(std::fabs(x), 0.5f * c.width) << c.name;
            const double e = std::fabs(nbFilterCdf(c.type, c.width, x) - u);
            worst = std::max(worst, e);
            EXPECT_LT(e, 1e-6) << c.name << " u " << u;  // a few float ulps of 1 (the CDF is evaluated in float)
        }
    std::printf("worst |CDF(sample(u)) - u| = %.3g\n", worst);
}

// 64 equal bins over the support; 10^6 samples from the hashed random stream the renderers use.
TEST(PixelFilter, ChiSquareOfTheSamplerAgainstTheProfile)
{
    const int bins = 64, n = 1000000;
    for (const Case& c : kCases) {
        const double r = 0.5 * c.width;
        std::vector<double> observed(bins, 0.0), expected(bins, 0.0);
        NbRng rng = nbRngStart(17u, 3u, 5u);
        for (int i = 0; i < n; ++i) {
            const float x = nbFilterSample(c.type, c.width, nbRngNext(&rng));
            const int b = std::min(bins - 1, int((x + r) / (2 * r) * bins));
            observed[b] += 1;
        }
        double chi2 = 0;
        int dof = -1;
        for (int b = 0; b < bins; ++b) {
            const double lo = -r + 2 * r * b / bins, hi = lo + 2 * r / bins;
            expected[b] =
                n * (double(nbFilterCdf(c.type, c.width, float(hi))) - nbFilterCdf(c.type, c.width, float(lo)));
            if (expected[b] < 5)
                continue;  // the Blackman-Harris window's far tails
            chi2 += (observed[b] - expected[b]) * (observed[b] - expected[b]) / expected[b];
            ++dof;
        }
        const double p = 1.0 - boost::math::cdf(boost::math::chi_squared(dof), chi2);
        EXPECT_GT(p, 1e-4) << c.name << ": chi2 " << chi2 << " with " << dof << " degrees of freedom";
    }
}

// The Gaussian's closed-form inverse: Giles's erf^-1 against Boost.Math's over the range used.
TEST(PixelFilter, ErfInvMatchesBoostOverTheGaussiansRange)
{
    double worst = 0;
    for (int i = -20000; i <= 20000; ++i) {
        const double x = 0.95449974 * i / 20000.0;
        worst = std::max(worst, std::fabs(double(nbErfInvCentral(float(x))) - boost::math::erf_inv(x)));
    }
    std::printf("worst |erfinv - boost::math::erf_inv| = %.3g\n", worst);
    EXPECT_LT(worst, 1e-6);  // Giles quotes ~3.4e-7 in single precision (measured 3.5e-7 here)
}
