// Equi-angular sampling (kernels/shared/equiangular.h, host build): the sampler against its pdf
// by chi-square (STYLE rule 13), the pdf's normalisation, and the MIS weight's limits.
#include "../../kernels/shared/equiangular.h"
#include "../../kernels/shared/rng.h"

#include <gtest/gtest.h>

#include <boost/math/distributions/chi_squared.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace {

struct Config {
    const char* name;
    float3 o, d, c;  // ray origin, direction (normalised here), the light
    float a, b;      // the segment
};

// The pdf integrated over [t0, t1] by the midpoint rule in double (independent of the sampler's
// inverse cdf).
double pdfIntegral(const NbEquiAngular& e, double t0, double t1, int m = 2000)
{
    double s = 0;
    for (int i = 0; i < m; ++i)
        s += nbEquiPdf(e, float(t0 + (i + 0.5) * (t1 - t0) / m));
    return s * (t1 - t0) / m;
}

class EquiAngularSampling : public ::testing::TestWithParam<Config> {};

// Samples fall into 64 bins uniform in t with the counts the pdf's formula predicts (Cochran
// pooling), and the pdf as evaluated (float) integrates to 1 over the segment.
TEST_P(EquiAngularSampling, SamplerMatchesPdfChiSquare)
{
    const Config cfg = GetParam();
    const float3 d = normalize(cfg.d);
    const NbEquiAngular e = nbEquiInit(cfg.o, d, cfg.c, cfg.a, cfg.b);

    // Normalisation: a graded split of [a, b] so the peak near the foot is resolved.
    std::vector<double> edges = {cfg.a, cfg.b, std::clamp(double(e.delta), double(cfg.a), double(cfg.b))};
    for (double k : {1.0, 3.0, 10.0, 30.0, 100.0, 300.0})
        for (double s : {-1.0, 1.0})
            edges.push_back(std::clamp(double(e.delta) + s * k * e.h, double(cfg.a), double(cfg.b)));
    std::sort(edges.begin(), edges.end());
    double total = 0;
    for (size_t i = 0; i + 1 < edges.size(); ++i)
        if (edges[i + 1] > edges[i])
            total += pdfIntegral(e, edges[i], edges[i + 1]);
    EXPECT_NEAR(total, 1.0, 2e-3) << cfg.name;

    // The cheap bound the kernel tests first never falls below the peak it stands for.
    const float peak = nbEquiPdf(e, std::clamp(e.delta, cfg.a, cfg.b));
    EXPECT_GE(nbEquiPeakBound(cfg.o, d, cfg.c, cfg.a, cfg.b), peak * (1 - 1e-5f)) << cfg.name;

    const int n = 400000, bins = 64;
    std::vector<double> observed(bins, 0.0), expected(bins, 0.0);
    const double width = double(cfg.b - cfg.a) / bins;
    for (int i = 0; i < n; ++i) {
        NbRng r = nbRngStart(11u, 3u, nb_uint(i));
        const float t = nbEquiSample(e, nbRngNext(&r));
        ASSERT_TRUE(t >= cfg.a && t <= cfg.b) << cfg.name << " sample " << i << ": t " << t;
        ASSERT_GT(nbEquiPdf(e, t), 0.0f) << cfg.name << " sample " << i;
        observed[std::min(bins - 1, int((t - cfg.a) / width))] += 1;
    }
    // Expected counts: the pdf's formula integrated exactly in double over each bin
    // (atan((t - Delta) / h) / (theta_b - theta_a)); a quadrature would not resolve the spike of
    // a ray through the light, whose width is the floored h.
    const double h = e.h, delta = e.delta;
    const double span = std::atan((cfg.b - delta) / h) - std::atan((cfg.a - delta) / h);
    for (int b = 0; b < bins; ++b) {
        const double t0 = cfg.a + b * width, t1 = cfg.a + (b + 1) * width;
        expected[b] = n * (std::atan((t1 - delta) / h) - std::atan((t0 - delta) / h)) / span;
    }
    double chi2 = 0, po = 0, pe = 0;
    int dof = -1;
    for (int b = 0; b < bins; ++b) {
        po += observed[b];
        pe += expected[b];
        if (pe >= 5) {
            chi2 += (po - pe) * (po - pe) / pe;
            po = pe = 0;
            ++dof;
        }
    }
    ASSERT_GT(dof, 0) << cfg.name;
    const double p = 1.0 - boost::math::cdf(boost::math::chi_squared(dof), chi2);
    std::printf("%s: h %.3g, normalisation %.5f, chi2 %.1f dof %d p %.3f\n", cfg.name, e.h, total, chi2, dof, p);
    EXPECT_GT(p, 1e-3) << cfg.name << ": chi2 " << chi2 << " dof " << dof;
}

INSTANTIATE_TEST_SUITE_P(
    Configs, EquiAngularSampling,
    ::testing::Values(Config{"near_inside", {0, 0, 0}, {0, 0, 1}, {0.05f, 0.02f, 1.3f}, 0.5f, 4.0f},
                      Config{"far", {1, 2, 3}, {1, -1, 0.5f}, {30.0f, 40.0f, -20.0f}, 0.0f, 6.0f},
                      Config{"light_before_segment", {0, 0, 0}, {1, 0, 0}, {-1.0f, 0.3f, 0.0f}, 0.2f, 3.0f},
                      Config{"light_after_segment", {0, 0, 0}, {0, 1, 0}, {0.0f, 5.0f, 0.4f}, 0.0f, 2.5f},
                      Config{"through_the_light", {0, 0, 0}, {0, 0, 1}, {0.0f, 0.0f, 2.0f}, 1.0f, 3.0f}),
    [](const ::testing::TestParamInfo<Config>& info) { return std::string(info.param.name); });

// The MIS weight: 1 where only equi-angular sampling can sample (tracking pdf 0), 0 outside the
// segment, 1/2 where the pdfs are equal, and the tracking's weight 1 - w is in [0, 1].
TEST(EquiAngularMis, WeightLimits)
{
    EXPECT_EQ(nbEquiMisWeight(2.0f, 0.0f), 1.0f);
    EXPECT_EQ(nbEquiMisWeight(0.0f, 3.0f), 0.0f);
    EXPECT_EQ(nbEquiMisWeight(0.0f, 0.0f), 0.0f);
    EXPECT_FLOAT_EQ(nbEquiMisWeight(0.7f, 0.7f), 0.5f);
    EXPECT_FLOAT_EQ(nbEquiMisWeight(1.0f, 2.0f), 0.2f);  // 1 / (1 + 4)
    EXPECT_EQ(nbEquiMisWeight(1e-30f, 1e30f), 0.0f);     // r^2 overflows: the tracking takes it all
    const NbEquiAngular e = nbEquiInit(make_float3(0, 0, 0), make_float3(0, 0, 1), make_float3(0, 1, 1), 0.0f, 2.0f);
    EXPECT_EQ(nbEquiPdf(e, -0.1f), 0.0f);
    EXPECT_EQ(nbEquiPdf(e, 2.1f), 0.0f);
    // At the foot of the perpendicular (t = 1, h = 1) the pdf is 1 / (theta_b - theta_a) = 2 / pi.
    EXPECT_NEAR(nbEquiPdf(e, 1.0f), 2.0 / M_PI, 1e-6);
}

// Equi-angular sampling is taken where its pdf's peak reaches NB_EQUI_MIN_PEAK times the largest
// majorant: the peak is at the foot when it lies on the segment, else at the nearer end.
TEST(EquiAngularMis, WorthwhileComparesThePeakWithTheMajorant)
{
    const float3 o = make_float3(0, 0, 0), d = make_float3(0, 0, 1);
    const NbEquiAngular inside = nbEquiInit(o, d, make_float3(0, 1, 1), 0.0f, 2.0f);  // peak 2 / pi
    EXPECT_TRUE(nbEquiWorthwhile(inside, 0.99f * (2.0f / float(M_PI)) / NB_EQUI_MIN_PEAK));
    EXPECT_FALSE(nbEquiWorthwhile(inside, 1.01f * (2.0f / float(M_PI)) / NB_EQUI_MIN_PEAK));
    const NbEquiAngular beyond = nbEquiInit(o, d, make_float3(0, 1, 5), 0.0f, 2.0f);  // peak at t = 2
    const float peak = nbEquiPdf(beyond, 2.0f);
    EXPECT_GT(peak, nbEquiPdf(beyond, 1.9f));
    EXPECT_TRUE(nbEquiWorthwhile(beyond, 0.99f * peak / NB_EQUI_MIN_PEAK));
    EXPECT_FALSE(nbEquiWorthwhile(beyond, 1.01f * peak / NB_EQUI_MIN_PEAK));
    EXPECT_TRUE(nbEquiWorthwhile(inside, 0.0f));  // no medium bound: always
}

}  // namespace
