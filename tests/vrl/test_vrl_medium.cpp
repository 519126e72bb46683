// VrlMedium::transmittance, residual ratio tracking (src/vrl/VrlMedium.h):
//  - in a homogeneous chromatic medium every estimate is e^{-sigma_t L} per channel, to float
//    rounding: the control extinction (the slot minorant) is the whole extinction, so no
//    tentative collision is drawn. Plain ratio tracking with the slot majorant (sigma_t times
//    1 + 1e-5) returns 0 or 1 there, and fails this;
//  - in heterogeneous, overlapping, chromatic media with empty bricks, the mean of many
//    estimates is e^{-int sigma_t} per channel, the integral by fine quadrature of
//    VolumeSet::sample (the host integrators' own lookup, not the walk's), within four standard
//    errors: the estimator stays unbiased where the control is only a bound.
#include "../pathtracer/PtWorld.h"

#include "../../kernels/shared/rng.h"
#include "pathtracer/PathtraceScene.h"
#include "vrl/VrlMedium.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

// Where o + t d (d unit) is inside the box [lo, hi]: the length of that stretch.
float lengthInside(float3 o, float3 d, float3 lo, float3 hi)
{
    float t0 = 0.0f, t1 = INFINITY;
    for (int a = 0; a < 3; ++a) {
        const float oa = component(o, a), da = component(d, a);
        const float ta = (component(lo, a) - oa) / da, tb = (component(hi, a) - oa) / da;
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
    }
    return std::max(0.0f, t1 - t0);
}

// Rays from a cube of half-size `reach` about the origin towards a point within `aim` of it.
struct RandomRays {
    std::mt19937 gen;
    std::uniform_real_distribution<float> u{-1, 1};
    float reach, aim;

    RandomRays(unsigned seed, float reach_, float aim_) : gen(seed), reach(reach_), aim(aim_) {}
    void next(float3& o, float3& d)
    {
        o = make_float3(reach * u(gen), reach * u(gen), reach * u(gen));
        d = normalize(make_float3(aim * u(gen), aim * u(gen), aim * u(gen)) - o);
    }
};

}  // namespace

TEST(VrlMedium, TransmittanceIsExactInAHomogeneousMedium)
{
    World w(4, 4);
    const float3 lo = make_float3(-1, -1, -1), hi = make_float3(1, 1, 1);
    // sigma_t (0.3, 0.5, 0.6): along the cube's longest chord the largest channel's transmittance
    // is e^{-0.3 * 3.46} = 0.35, above the roulette's 0.1, so every estimate is the exact value.
    w.volumes = {boxVolume(lo, hi, {3, 3, 3}, medium(make_float3(0.25f, 0.4f, 0.3f), make_float3(0.05f, 0.1f, 0.3f)))};
    PathtraceScene ps = buildPathtraceScene(w.context());
    const vrl::VrlMedium m(ps);
    RandomRays rays(3, 3.0f, 0.5f);
    NbRng rng = nbRngStart(5, 1, 2);
    int crossing = 0;
    for (int r = 0; r < 50; ++r) {
        float3 o, d;
        rays.next(o, d);
        const float L = lengthInside(o, d, lo, hi);
        const float3 sigmaT = make_float3(0.3f, 0.5f, 0.6f);
        crossing += L > 1.0f;
        for (int k = 0; k < 20; ++k) {
            const float3 T = m.transmittance(o, d, 10.0f, rng);
            for (int c = 0; c < 3; ++c) {
                const double exact = std::exp(-double(component(sigmaT, c)) * L);
                ASSERT_NEAR(component(T, c), exact, 2e-5 + 2e-5 * exact)
                    << "ray " << r << " channel " << c << ": length " << L << " inside";
            }
        }
    }
    EXPECT_GE(crossing, 20) << "too few rays cross the medium";
}

TEST(VrlMedium, TransmittanceIsUnbiasedInHeterogeneousChromaticMedia)
{
    World w(4, 4);
    // A cloud with holes (empty bricks) and a second, overlapping volume of another colour.
    auto a =
        boxVolume(make_float3(-1, -1, -1), make_float3(1, 1, 1), {3, 3, 3}, medium(make_float3(1, 2, 3), splat(0.5f)),
                  [](float3 p) {
                      const float r = length(p - splat(0.5f));
                      return r < 0.45f ? (0.6f + 0.4f * std::sin(9 * p.x) * std::cos(7 * p.y)) * (r > 0.15f) : 0.0f;
                  });
    auto b = boxVolume(make_float3(-0.3f, -0.8f, -0.2f), make_float3(0.9f, 0.5f, 0.4f), {2, 2, 1},
                       medium(make_float3(3, 1, 0.5f), splat(0.2f)), [](float3 p) { return 0.5f + 0.5f * p.x; });
    w.volumes = {a, b};
    const RenderContext& ctx = w.context();
    PathtraceScene ps = buildPathtraceScene(ctx);
    const vrl::VrlMedium m(ps);
    RandomRays rays(11, 2.5f, 0.4f);
    NbRng rng = nbRngStart(9, 4, 1);
    int checked = 0;
    for (int r = 0; r < 12; ++r) {
        float3 o, d;
        rays.next(o, d);
        const float tMax = 6.0f;
        // e^{-int sigma_t}: midpoint rule on 20000 steps.
        double tau[3] = {0, 0, 0};
        const int steps = 20000;
        for (int k = 0; k < steps; ++k) {
            const float t = tMax * (k + 0.5f) / steps;
            const MediumSample s = ctx.volumes.sample(o + d * t);
            for (int c = 0; c < 3; ++c)
                tau[c] += double(component(s.sigma_t, c)) * tMax / steps;
        }
        const int n = 20000;
        double s1[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
        for (int k = 0; k < n; ++k) {
            const float3 T = m.transmittance(o, d, tMax, rng);
            for (int c = 0; c < 3; ++c) {
                s1[c] += component(T, c);
                s2[c] += double(component(T, c)) * component(T, c);
            }
        }
        for (int c = 0; c < 3; ++c) {
            const double exact = std::exp(-tau[c]), mean = s1[c] / n;
            const double se = std::sqrt(std::max(0.0, s2[c] / n - mean * mean) / n);
            EXPECT_NEAR(mean, exact, 4 * se + 1e-3 * exact + 1e-6)
                << "ray " << r << " channel " << c << ": optical depth " << tau[c];
        }
        checked += tau[0] > 0.05;
    }
    EXPECT_GE(checked, 6) << "too few rays met the media";
}
