// Chi-square tests of the VRL joint distributions (src/vrl/JointSampling.h): the pairs (u, v)
// drawn by sample() against the pdf() that the estimator divides by, for several line
// configurations (crossing, parallel, skew, far apart, nearly touching) and Henyey-Greenstein
// g in {-0.9, 0, 0.5, 0.95}, for both the simple (Oppitz 7.3.1) and the advanced (7.3.2)
// distribution (Mitsuba 3's chi2 tests are the model).
//
// The expected count of a bin is the pdf integrated over it by Gauss-Legendre quadrature in
// variables that flatten its peaks, computed here from the line geometry independently of the
// sampler: v = v_h + h sinh(s) / sin(theta) (the 1 / h(v) marginal), and for each v,
// u = u_f + h_v tan(phi) (the 1 / w^2 conditional). Bins: 12 in v, uniform in s (equal marginal
// mass for the simple distribution), times 12 in u, uniform in u; bins expecting fewer than 5
// samples are pooled. The test fails at p < 1e-3 / (number of tests) (Sidak-style); the
// integral of the pdf over the whole domain must be 1 to 1e-3 as well.
#include "vrl/JointSampling.h"

#include "../../kernels/shared/rng.h"

#include <boost/math/distributions/chi_squared.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace nimbus::vrl {
namespace {

constexpr int kBinsU = 12, kBinsV = 12;
constexpr int kSamples = 200000;
constexpr int kTests = 5 * 4 * 2;
constexpr double kAlpha = 1e-3 / kTests;

// 16-point Gauss-Legendre nodes and weights on [-1, 1].
const double kGlX[8] = {0.0950125098376374, 0.2816035507792589, 0.4580167776572274, 0.6178762444026438,
                        0.7554044083550030, 0.8656312023878318, 0.9445750230732326, 0.9894009349916499};
const double kGlW[8] = {0.1894506104550685, 0.1826034150449236, 0.1691565193950025, 0.1495959888165767,
                        0.1246289712555339, 0.0951585116824928, 0.0622535239386479, 0.0271524594117541};

template <class F>
double gauss(double a, double b, F f)
{
    const double c = 0.5 * (a + b), r = 0.5 * (b - a);
    double s = 0;
    for (int i = 0; i < 8; ++i)
        s += kGlW[i] * (f(c - r * kGlX[i]) + f(c + r * kGlX[i]));
    return s * r;
}

// Gauss-Legendre on [a, b] split into n panels.
template <class F>
double panels(double a, double b, int n, F f)
{
    double s = 0;
    for (int i = 0; i < n; ++i)
        s += gauss(a + (b - a) * i / n, a + (b - a) * (i + 1) / n, f);
    return s;
}

struct Config {
    const char* name;
    LinePair lines;
};

float3 unit(float x, float y, float z)
{
    return normalize(make_float3(x, y, z));
}

std::vector<Config> configs()
{
    std::vector<Config> c;
    LinePair l;
    // Crossing: the VRL passes through the camera ray's point u = 2.
    l.oU = make_float3(0, 0, 0), l.dU = unit(0, 0, 1), l.u0 = 0.5, l.u1 = 4;
    l.oV = make_float3(-1, 0, 1), l.dV = unit(1, 0, 1), l.v0 = 0.2, l.v1 = 3;
    c.push_back({"crossing", l});
    // Parallel, 0.3 m apart.
    l.oV = make_float3(0.3f, 0, -1), l.dV = unit(0, 0, 1), l.v0 = 0, l.v1 = 5;
    c.push_back({"parallel", l});
    // Skew, 0.5 m apart at the closest points, 60 degrees between them.
    l.oV = make_float3(0, 0.5f, 2), l.dV = unit(std::sqrt(3.0f), 0, 1), l.v0 = -1.5, l.v1 = 2;
    c.push_back({"skew", l});
    // Far apart: 20 m, nearly perpendicular, short segments.
    l.oV = make_float3(0, 20, 1), l.dV = unit(1, 0, 0.1f), l.v0 = -2, l.v1 = 1;
    c.push_back({"far_apart", l});
    // Nearly touching: 1 mm at the closest points, inside both segments.
    l.oV = make_float3(0, 0.001f, 2), l.dV = unit(1, 0, 0.3f), l.v0 = -1, l.v1 = 2;
    c.push_back({"nearly_touching", l});
    return c;
}

// The test's own geometry: where the lines come closest, their distance and the angle.
struct Geometry {
    double vh, h, sinTheta;
    double floor;  // the sampler's floor on distances
};

Geometry geometry(const LinePair& l)
{
    const double dux = l.dU.x, duy = l.dU.y, duz = l.dU.z, dvx = l.dV.x, dvy = l.dV.y, dvz = l.dV.z;
    const double wx = l.oU.x - l.oV.x, wy = l.oU.y - l.oV.y, wz = l.oU.z - l.oV.z;
    const double b = dux * dvx + duy * dvy + duz * dvz;
    const double d = dux * wx + duy * wy + duz * wz, e = dvx * wx + dvy * wy + dvz * wz;
    const double cx = duy * dvz - duz * dvy, cy = duz * dvx - dux * dvz, cz = dux * dvy - duy * dvx;
    Geometry g;
    g.sinTheta = std::sqrt(cx * cx + cy * cy + cz * cz);
    double uh = -d;
    g.vh = 0;
    if (g.sinTheta > 1e-6) {
        uh = (b * e - d) / (1 - b * b);
        g.vh = e + uh * b;
    }
    const double px = wx + uh * dux - g.vh * dvx, py = wy + uh * duy - g.vh * dvy, pz = wz + uh * duz - g.vh * dvz;
    // The sampler's floor on distances (JointSampling.h): crossing lines peak at this width, and a
    // substantial share of their mass lies within it.
    g.floor = 1e-6 * ((l.u1 - l.u0) + (l.v1 - l.v0)) + 1e-9;
    g.h = std::max(std::sqrt(px * px + py * py + pz * pz), g.floor);
    return g;
}

// v(s) and dv/ds; parallel lines: v = s.
double vOf(const Geometry& g, double s, double& jac)
{
    if (g.sinTheta < 1e-6) {
        jac = 1;
        return s;
    }
    jac = g.h * std::cosh(s) / g.sinTheta;
    return g.vh + g.h * std::sinh(s) / g.sinTheta;
}
double sOf(const Geometry& g, double v)
{
    return g.sinTheta < 1e-6 ? v : std::asinh((v - g.vh) * g.sinTheta / g.h);
}

// The integral of pdf(u, v) over [ua, ub] x [va, vb], in the flattening variables.
double binMass(const JointSampler& js, const LinePair& l, const Geometry& g, double ua, double ub, double va, double vb)
{
    return panels(sOf(g, va), sOf(g, vb), 2, [&](double s) {
        double jv;
        const double v = vOf(g, s, jv);
        // v's foot on the camera line and its distance.
        const double px = l.oV.x + v * l.dV.x - l.oU.x, py = l.oV.y + v * l.dV.y - l.oU.y,
                     pz = l.oV.z + v * l.dV.z - l.oU.z;
        const double tf = px * l.dU.x + py * l.dU.y + pz * l.dU.z;
        const double qx = px - tf * l.dU.x, qy = py - tf * l.dU.y, qz = pz - tf * l.dU.z;
        const double hv = std::max(std::sqrt(qx * qx + qy * qy + qz * qz), g.floor);
        const double inner = panels(std::atan((ua - tf) / hv), std::atan((ub - tf) / hv), 12, [&](double phi) {
            const double t = std::tan(phi);
            const double u = tf + hv * t;
            return js.pdf(u, v) * hv * (1 + t * t);
        });
        return inner * jv;
    });
}

class JointChi2 : public ::testing::TestWithParam<std::tuple<int, float, JointKind>> {};

TEST_P(JointChi2, SamplesFollowPdf)
{
    const auto [configIndex, g, kind] = GetParam();
    const Config cfg = configs()[size_t(configIndex)];
    const LinePair& l = cfg.lines;
    const PhasePair phases{NbPhase{g, 0, 0, 0}, NbPhase{g, 0, 0, 0}};
    const JointSampler js(l, kind, phases);
    const Geometry geo = geometry(l);

    std::vector<double> uEdges(kBinsU + 1), vEdges(kBinsV + 1);
    for (int i = 0; i <= kBinsU; ++i)
        uEdges[size_t(i)] = l.u0 + (l.u1 - l.u0) * i / kBinsU;
    const double s0 = sOf(geo, l.v0), s1 = sOf(geo, l.v1);
    for (int j = 0; j <= kBinsV; ++j) {
        double jac;
        vEdges[size_t(j)] = j == 0 ? l.v0 : j == kBinsV ? l.v1 : vOf(geo, s0 + (s1 - s0) * j / kBinsV, jac);
    }

    std::vector<double> observed(size_t(kBinsU * kBinsV), 0.0), expected(observed.size(), 0.0);
    NbRng rng = nbRngStart(1234u, nb_uint(configIndex), nb_uint(std::lround(g * 100) + 1000 * int(kind)));
    int bad = 0;
    for (int n = 0; n < kSamples; ++n) {
        const float xi0 = nbRngNext(&rng), xi1 = nbRngNext(&rng);
        const PairSample s = js.sample(xi0, xi1);
        // The pdf a sample reports is the pdf evaluated at it.
        const double p = js.pdf(s.u, s.v);
        if (!(s.pdf > 0) || std::fabs(s.pdf - p) > 1e-6 * p + 1e-12) {
            if (++bad < 5)
                ADD_FAILURE() << cfg.name << ": sample " << n << " (xi " << xi0 << ", " << xi1 << ") u " << s.u << " v "
                              << s.v << " reports pdf " << s.pdf << ", pdf() says " << p;
            continue;
        }
        const int iu =
            std::min(kBinsU - 1, int(std::upper_bound(uEdges.begin(), uEdges.end(), s.u) - uEdges.begin()) - 1);
        const int iv =
            std::min(kBinsV - 1, int(std::upper_bound(vEdges.begin(), vEdges.end(), s.v) - vEdges.begin()) - 1);
        observed[size_t(std::max(0, iv) * kBinsU + std::max(0, iu))] += 1;
    }
    double total = 0;
    for (int j = 0; j < kBinsV; ++j)
        for (int i = 0; i < kBinsU; ++i) {
            const double m =
                binMass(js, l, geo, uEdges[size_t(i)], uEdges[size_t(i + 1)], vEdges[size_t(j)], vEdges[size_t(j + 1)]);
            expected[size_t(j * kBinsU + i)] = m * kSamples;
            total += m;
        }
    EXPECT_NEAR(total, 1.0, 1e-3) << cfg.name << ": the pdf does not integrate to 1";

    // Pool bins expecting fewer than 5 samples (Mitsuba's rule), then Pearson's statistic.
    double chi2 = 0, poolObs = 0, poolExp = 0;
    int dof = -1;
    for (size_t k = 0; k < observed.size(); ++k) {
        if (expected[k] < 5) {
            poolObs += observed[k];
            poolExp += expected[k];
            continue;
        }
        chi2 += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
        ++dof;
    }
    if (poolExp >= 5) {
        chi2 += (poolObs - poolExp) * (poolObs - poolExp) / poolExp;
        ++dof;
    } else {
        EXPECT_LT(poolObs, 5 + 5 * poolExp) << cfg.name << ": samples where the pdf expects almost none";
    }
    ASSERT_GT(dof, 5);
    const double pValue = boost::math::cdf(boost::math::complement(boost::math::chi_squared(dof), chi2));
    EXPECT_GT(pValue, kAlpha) << cfg.name << " g " << g << (kind == JointKind::Simple ? " simple" : " advanced")
                              << ": chi2 " << chi2 << " with " << dof << " dof";
    if (pValue <= kAlpha)
        for (int j = 0; j < kBinsV; ++j) {
            std::string row;
            for (int i = 0; i < kBinsU; ++i) {
                char b[48];
                std::snprintf(b, sizeof b, " %6.0f/%6.0f", observed[size_t(j * kBinsU + i)],
                              expected[size_t(j * kBinsU + i)]);
                row += b;
            }
            std::printf("v bin %2d:%s\n", j, row.c_str());
        }
}

INSTANTIATE_TEST_SUITE_P(Configurations, JointChi2,
                         ::testing::Combine(::testing::Range(0, 5), ::testing::Values(-0.9f, 0.0f, 0.5f, 0.95f),
                                            ::testing::Values(JointKind::Simple, JointKind::Advanced)));

// The advanced distribution puts more samples where the product of the phase functions is large:
// for a forward-peaked medium its samples' mean phase product beats the simple one's (what 7.3.2
// is for).
TEST(JointSampling, AdvancedFollowsThePhaseProduct)
{
    LinePair l = configs()[2].lines;
    const NbPhase p{0.9f, 0, 0, 0};
    const JointSampler simple(l, JointKind::Simple), advanced(l, JointKind::Advanced, PhasePair{p, p});
    auto meanProduct = [&](const JointSampler& js) {
        NbRng rng = nbRngStart(7u, 0u, 0u);
        double sum = 0;
        for (int n = 0; n < 20000; ++n) {
            const PairSample s = js.sample(nbRngNext(&rng), nbRngNext(&rng));
            const float3 pu = l.oU + l.dU * float(s.u), pv = l.oV + l.dV * float(s.v);
            const float3 w = normalize(pu - pv);
            sum += double(nbPhaseEval(p, dot(l.dV, w))) * nbPhaseEval(p, -dot(w, l.dU));
        }
        return sum / 20000;
    };
    EXPECT_GT(meanProduct(advanced), 1.5 * meanProduct(simple));
}

}  // namespace
}  // namespace nimbus::vrl
