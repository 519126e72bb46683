// Multiple scattering against independent solutions: the radiance reflected and diffusely
// transmitted by a homogeneous plane-parallel slab under a normally incident distant light, at
// the 8 Gauss-Legendre cosines, and the hemispherical reflectance and transmittance they
// integrate to. References: SlabSolver.h (isotropic: the Schwarzschild-Milne integral equation)
// and DomSlabSolver.h (HG: discrete ordinates), both checked against published tables, and the
// path tracer too, in test_pathtrace_slab_published.cpp. The two solvers are different methods
// and must agree where both apply (g = 0).
// Also a single-scattering HG slab with closed forms, which pins down the direction convention
// of the phase function (forward scattering brightens transmission, not reflection).
//
// The slab is a box 1 m thick and 4 km wide: paths reaching its sides are negligible. Each
// direction is one render of 8 x 8 pixels through a 0.01 degree field of view: the slab being
// laterally uniform, every pixel estimates the same radiance independently. 64 pixels, so the
// standard error estimated from their scatter is itself good to ~9%.
#include "DomSlabSolver.h"
#include "PtWorld.h"
#include "SlabSolver.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

constexpr double kSigmas = 4.0;
constexpr float kHalfWidth = 2000.0f;

struct SlabCase {
    float tau0, albedo, g;
};

// Renders the slab y in [0, 1] (lit from above: the light travels along -y) seen at cosine mu
// from above (reflection) or from below (transmission). Returns mean and standard error.
PixelStats renderSlab(SlabCase c, double mu, bool fromAbove, int maxDepth, int spp, uint32_t seed,
                      PathtraceStats* stats = nullptr)
{
    World w(8, 8);
    w.volumes.push_back(
        boxVolume(make_float3(-kHalfWidth, 0, -kHalfWidth), make_float3(kHalfWidth, 1, kHalfWidth), {1, 1, 1},
                  medium(splat(c.albedo * c.tau0), splat((1 - c.albedo) * c.tau0), NbPhase{c.g, 0, 0, 0})));
    w.addLight(distantLight(make_float3(0, -1, 0), splat(1.0f)));
    const double s = std::sqrt(std::max(0.0, 1 - mu * mu)), D = 2.0;
    const float3 target = make_float3(0, fromAbove ? 1.0f : 0.0f, 0);
    const float3 from = target + make_float3(float(s * D), float((fromAbove ? 1 : -1) * mu * D), 0);
    lookAt(w.scene, from, target, 0.01f, make_float3(0, 0, 1));
    w.scene.render.maxDepth = maxDepth;
    w.scene.render.spp = spp;
    w.scene.render.seed = seed;
    PathtraceOptions pt;
    pt.stats = stats;
    Film f = w.render(pt);
    return pixelStats(f, "beauty", 0);
}

// The reference radiance and fluxes for a case (per unit beam irradiance), and the solver's own
// discretisation error in R + T from a coarser solve.
struct Reference {
    std::function<double(double)> top, bottom;
    double R = 0, T = 0, error = 0;
};

Reference reference(SlabCase c)
{
    Reference r;
    if (c.g == 0.0f) {
        auto fine = std::make_shared<SlabSolver>(c.tau0, c.albedo, 2000);
        SlabSolver coarse(c.tau0, c.albedo, 1000);
        r.top = [fine](double mu) { return fine->top(mu); };
        r.bottom = [fine](double mu) { return fine->bottom(mu); };
        r.R = fine->reflectance();
        r.T = fine->diffuseTransmittance();
        r.error = std::fabs(r.R - coarse.reflectance()) + std::fabs(r.T - coarse.diffuseTransmittance());
    } else {
        auto fine = std::make_shared<DomSlabSolver>(c.tau0, c.albedo, c.g, 16, 1000);
        DomSlabSolver coarse(c.tau0, c.albedo, c.g, 12, 500);
        r.top = [fine](double mu) { return fine->top(mu); };
        r.bottom = [fine](double mu) { return fine->bottom(mu); };
        r.R = fine->reflectance();
        r.T = fine->diffuseTransmittance();
        r.error = std::fabs(r.R - coarse.reflectance()) + std::fabs(r.T - coarse.diffuseTransmittance());
    }
    return r;
}

}  // namespace

// Two different methods, one answer: discrete ordinates at g = 0 against the Milne equation.
TEST(SlabSolvers, DiscreteOrdinatesAgreeWithMilneEquationForIsotropicScattering)
{
    for (SlabCase c : {SlabCase{1.0f, 0.9f, 0.0f}, SlabCase{2.0f, 1.0f, 0.0f}}) {
        SlabSolver milne(c.tau0, c.albedo, 2000);
        DomSlabSolver dom(c.tau0, c.albedo, 0.0, 16, 1000);
        EXPECT_NEAR(dom.reflectance(), milne.reflectance(), 1e-5);
        EXPECT_NEAR(dom.diffuseTransmittance(), milne.diffuseTransmittance(), 1e-5);
        for (double mu : {0.05, 0.3, 0.7, 1.0}) {
            EXPECT_NEAR(dom.top(mu), milne.top(mu), 1e-5) << mu;
            EXPECT_NEAR(dom.bottom(mu), milne.bottom(mu), 1e-5) << mu;
        }
    }
}

class SlabMultiple : public ::testing::TestWithParam<SlabCase> {};

TEST_P(SlabMultiple, RadianceAndFluxesMatchIndependentSolution)
{
    useTestKernelCache("slab");
    const SlabCase c = GetParam();
    const Reference ref = reference(c);
    const double solverError = ref.error;
    if (c.albedo == 1.0f) {
        EXPECT_NEAR(ref.R + ref.T + std::exp(-double(c.tau0)), 1.0, 1e-5) << "solver: flux not conserved";
    }

    std::vector<double> mu, weight;
    gaussLegendre01(8, mu, weight);
    double R = 0, T = 0, varR = 0, varT = 0, Rnodes = 0, Tnodes = 0;
    for (size_t k = 0; k < mu.size(); ++k) {
        for (bool above : {true, false}) {
            PixelStats s = renderSlab(c, mu[k], above, 100000, 256, 11 + uint32_t(k));
            double exact = above ? ref.top(mu[k]) : ref.bottom(mu[k]);
            double z = (s.mean - exact) / s.standardError;
            std::printf("tau0 %.1f a %.2f g %.1f %s mu %.4f: pt %.5f solver %.5f se %.1e z %+.2f\n", c.tau0, c.albedo,
                        c.g, above ? "reflected  " : "transmitted", mu[k], s.mean, exact, s.standardError, z);
            EXPECT_LT(std::fabs(z), kSigmas) << (above ? "reflected" : "transmitted") << " radiance at mu " << mu[k];
            double f = 2 * M_PI * weight[k] * mu[k];
            (above ? R : T) += f * s.mean;
            (above ? varR : varT) += f * f * s.standardError * s.standardError;
            (above ? Rnodes : Tnodes) += f * exact;
        }
    }
    // The 8-node quadrature of the solver's radiance against its exact flux: the quadrature
    // error (reported, not tested), then the path tracer's fluxes against the same quadrature.
    std::printf(
        "tau0 %.1f a %.2f g %.1f: R pt %.5f +- %.5f, quadrature of solver %.5f, solver %.6f (solver error %.1e)\n",
        c.tau0, c.albedo, c.g, R, std::sqrt(varR), Rnodes, ref.R, solverError);
    std::printf("tau0 %.1f a %.2f g %.1f: T pt %.5f +- %.5f, quadrature of solver %.5f, solver %.6f\n", c.tau0,
                c.albedo, c.g, T, std::sqrt(varT), Tnodes, ref.T);
    EXPECT_LT(std::fabs(R - Rnodes), kSigmas * std::sqrt(varR));
    EXPECT_LT(std::fabs(T - Tnodes), kSigmas * std::sqrt(varT));
}

INSTANTIATE_TEST_SUITE_P(Slabs, SlabMultiple,
                         ::testing::Values(SlabCase{1.0f, 0.9f, 0.0f}, SlabCase{2.0f, 1.0f, 0.0f},
                                           SlabCase{2.0f, 1.0f, 0.5f}, SlabCase{1.0f, 0.9f, 0.7f}),
                         [](const ::testing::TestParamInfo<SlabCase>& i) {
                             return "tau" + std::to_string(int(i.param.tau0)) + "_albedo" +
                                    std::to_string(int(std::lround(100 * i.param.albedo))) + "_g" +
                                    std::to_string(int(std::lround(10 * i.param.g)));
                         });

// Single scattering (max depth 1) in an HG slab, normal incidence, closed forms per channel:
//   reflected   I(mu) = a p(-mu) E (1 - e^{-tau0 (1 + 1/mu)}) / (1 + mu)
//   transmitted I(mu) = a p(+mu) E (e^{-tau0} - e^{-tau0/mu}) / (1 - mu)
// (light travels down, leaves up toward a viewer above: cos = -mu; down toward one below:
// cos = +mu). With g = 0.7 the two differ by two orders of magnitude, so a reversed phase
// convention cannot pass.
TEST(SlabSingle, HgReflectionAndTransmissionClosedForm)
{
    useTestKernelCache("slab");
    const SlabCase c{1.5f, 0.8f, 0.7f};
    for (double mu : {0.3, 0.7}) {
        for (bool above : {true, false}) {
            PixelStats s = renderSlab(c, mu, above, 1, 256, 5);
            double p = nbHgEval(c.g, float(above ? -mu : mu));
            double exact = above ? c.albedo * p * (1 - std::exp(-c.tau0 * (1 + 1 / mu))) / (1 + mu)
                                 : c.albedo * p * (std::exp(-c.tau0) - std::exp(-c.tau0 / mu)) / (1 - mu);
            double z = (s.mean - exact) / s.standardError;
            std::printf("HG single %s mu %.1f: pt %.6f exact %.6f se %.1e z %+.2f\n",
                        above ? "reflected  " : "transmitted", mu, s.mean, exact, s.standardError, z);
            EXPECT_LT(std::fabs(z), kSigmas);
        }
    }
}

// The reference must not be truncated (issue 13): a thick, bright half-space (tau 32 is a
// half-space to 1e-5 here, isotropic, albedo 0.99, seen along the normal under normal incidence)
// keeps 5.1% of its reflected radiance in paths of more than 64 scattering events. The default
// max_depth is unbounded and must reproduce the full solution; max_depth 64 must reproduce the
// solution without those paths (the Neumann series truncated after 64 orders), so a cap is still
// a cap. The render's noise is small against the gap between the two answers, so either test
// fails if the other depth were used. The solver's discretisation error (two resolutions) is
// added to the standard error.
namespace {

struct HalfSpaceCheck {
    double mean, se, full, capped, solverError;
};

HalfSpaceCheck renderHalfSpace(float albedo, int maxDepth, int spp, uint32_t seed, PathtraceStats* stats)
{
    const SlabCase c{32.0f, albedo, 0.0f};
    const int cells = 1280;
    const SlabSolver full(c.tau0, c.albedo, cells), coarse(c.tau0, c.albedo, cells / 2);
    const SlabSolver capped(c.tau0, c.albedo, cells, 1.0, 64);
    const PixelStats s = renderSlab(c, 1.0, true, maxDepth, spp, seed, stats);
    return {s.mean, s.standardError, full.top(1.0), capped.top(1.0), std::fabs(full.top(1.0) - coarse.top(1.0))};
}

}  // namespace

TEST(SlabHalfSpace, DefaultDepthIsUnboundedAndMatchesTheFullSolution)
{
    useTestKernelCache("slab");
    EXPECT_EQ(RenderSettings{}.maxDepth, 0) << "the default max_depth is unbounded";
    PathtraceStats stats;
    const HalfSpaceCheck h = renderHalfSpace(0.99f, RenderSettings{}.maxDepth, 1024, 21, &stats);
    const double sigma = std::hypot(h.se, h.solverError);
    std::printf("half-space a 0.99 default depth: pt %.5f +- %.5f, full %.5f (z %+.2f), capped at 64 %.5f (z %+.2f)\n",
                h.mean, h.se, h.full, (h.mean - h.full) / sigma, h.capped, (h.mean - h.capped) / sigma);
    EXPECT_LT(std::fabs(h.mean - h.full), kSigmas * sigma);
    EXPECT_GT(std::fabs(h.full - h.capped), 2 * kSigmas * sigma) << "too noisy to tell a depth cap of 64";
    EXPECT_EQ(stats.depthCapped, 0);
}

TEST(SlabHalfSpace, MaxDepthStillCaps)
{
    useTestKernelCache("slab");
    const HalfSpaceCheck h = renderHalfSpace(0.99f, 64, 1024, 22, nullptr);
    const double sigma = std::hypot(h.se, h.solverError);
    std::printf("half-space a 0.99 max_depth 64: pt %.5f +- %.5f, capped at 64 %.5f (z %+.2f), full %.5f (z %+.2f)\n",
                h.mean, h.se, h.capped, (h.mean - h.capped) / sigma, h.full, (h.mean - h.full) / sigma);
    EXPECT_LT(std::fabs(h.mean - h.capped), kSigmas * sigma);
    EXPECT_GT(std::fabs(h.full - h.capped), 2 * kSigmas * sigma);
}

// Albedo 0.9999: a fifth of the light comes back after more than 64 events, and only Russian
// roulette (or escape) ends a path. Every path must end before the safety cap.
TEST(SlabHalfSpace, RussianRouletteEndsPathsAtAlbedo09999)
{
    useTestKernelCache("slab");
    PathtraceStats stats;
    const HalfSpaceCheck h = renderHalfSpace(0.9999f, 0, 256, 23, &stats);
    const double sigma = std::hypot(h.se, h.solverError);
    std::printf("slab tau 32 a 0.9999 unbounded: pt %.5f +- %.5f, full %.5f (z %+.2f), capped at 64 %.5f; %.2f s\n",
                h.mean, h.se, h.full, (h.mean - h.full) / sigma, h.capped, stats.renderSeconds);
    EXPECT_LT(std::fabs(h.mean - h.full), kSigmas * sigma);
    EXPECT_EQ(stats.depthCapped, 0);
    EXPECT_EQ(stats.badSamples, 0);
}
