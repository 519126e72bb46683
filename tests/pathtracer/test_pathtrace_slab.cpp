// Multiple scattering against an independent solution: the radiance reflected and diffusely
// transmitted by a homogeneous, isotropically scattering plane-parallel slab under a normally
// incident distant light, at the 8 Gauss-Legendre cosines, and the hemispherical reflectance
// and transmittance they integrate to. The reference is SlabSolver.h (the Schwarzschild-Milne
// integral equation solved deterministically; see there why not a published table).
// Also a single-scattering HG slab with closed forms, which pins down the direction convention
// of the phase function (forward scattering brightens transmission, not reflection).
//
// The slab is a box 1 m thick and 4 km wide: paths reaching its sides are negligible. Each
// direction is one render of 4 x 4 pixels through a 0.01 degree field of view: the slab being
// laterally uniform, every pixel estimates the same radiance independently.
#include "PtWorld.h"
#include "SlabSolver.h"

#include <gtest/gtest.h>

#include <cmath>

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
PixelStats renderSlab(SlabCase c, double mu, bool fromAbove, int maxDepth, int spp, uint32_t seed)
{
    World w(4, 4);
    w.volumes.push_back(boxVolume(make_float3(-kHalfWidth, 0, -kHalfWidth), make_float3(kHalfWidth, 1, kHalfWidth),
                                  {1, 1, 1},
                                  medium(splat(c.albedo * c.tau0), splat((1 - c.albedo) * c.tau0), NbPhase{c.g, 0, 0, 0})));
    w.addLight(distantLight(make_float3(0, -1, 0), splat(1.0f)));
    const double s = std::sqrt(std::max(0.0, 1 - mu * mu)), D = 2.0;
    const float3 target = make_float3(0, fromAbove ? 1.0f : 0.0f, 0);
    const float3 from = target + make_float3(float(s * D), float((fromAbove ? 1 : -1) * mu * D), 0);
    lookAt(w.scene, from, target, 0.01f, make_float3(0, 0, 1));
    w.scene.render.maxDepth = maxDepth;
    w.scene.render.spp = spp;
    w.scene.render.seed = seed;
    Film f = w.render();
    return pixelStats(f, "beauty", 0);
}

}  // namespace

class SlabMultiple : public ::testing::TestWithParam<SlabCase> {};

TEST_P(SlabMultiple, RadianceAndFluxesMatchIndependentSolution)
{
    useTestKernelCache("slab");
    const SlabCase c = GetParam();
    SlabSolver fine(c.tau0, c.albedo, 2000), coarse(c.tau0, c.albedo, 1000);
    // The solver's own error, from halving its cell size (it converges as h^2).
    const double solverError = std::fabs(fine.reflectance() - coarse.reflectance()) +
                               std::fabs(fine.diffuseTransmittance() - coarse.diffuseTransmittance());
    if (c.albedo == 1.0f) {
        EXPECT_NEAR(fine.reflectance() + fine.diffuseTransmittance() + std::exp(-double(c.tau0)), 1.0, 1e-5)
            << "solver: flux not conserved";
    }

    std::vector<double> mu, weight;
    gaussLegendre01(8, mu, weight);
    double R = 0, T = 0, varR = 0, varT = 0, Rnodes = 0, Tnodes = 0;
    for (size_t k = 0; k < mu.size(); ++k) {
        for (bool above : {true, false}) {
            PixelStats s = renderSlab(c, mu[k], above, 100000, 1024, 11 + uint32_t(k));
            double exact = above ? fine.top(mu[k]) : fine.bottom(mu[k]);
            double z = (s.mean - exact) / s.standardError;
            std::printf("tau0 %.1f a %.2f %s mu %.4f: pt %.5f solver %.5f se %.1e z %+.2f\n", c.tau0, c.albedo,
                        above ? "reflected  " : "transmitted", mu[k], s.mean, exact, s.standardError, z);
            EXPECT_LT(std::fabs(z), kSigmas) << (above ? "reflected" : "transmitted") << " radiance at mu " << mu[k];
            double f = 2 * M_PI * weight[k] * mu[k];
            (above ? R : T) += f * s.mean;
            (above ? varR : varT) += f * f * s.standardError * s.standardError;
            (above ? Rnodes : Tnodes) += f * exact;
        }
    }
    // The 8-node quadrature of the solver's radiance against its exact flux: the quadrature
    // error (reported, not tested), then the path tracer's fluxes against the same quadrature.
    std::printf("tau0 %.1f a %.2f: R pt %.5f +- %.5f, quadrature of solver %.5f, solver %.6f (solver error %.1e)\n",
                c.tau0, c.albedo, R, std::sqrt(varR), Rnodes, fine.reflectance(), solverError);
    std::printf("tau0 %.1f a %.2f: T pt %.5f +- %.5f, quadrature of solver %.5f, solver %.6f\n", c.tau0, c.albedo, T,
                std::sqrt(varT), Tnodes, fine.diffuseTransmittance());
    EXPECT_LT(std::fabs(R - Rnodes), kSigmas * std::sqrt(varR));
    EXPECT_LT(std::fabs(T - Tnodes), kSigmas * std::sqrt(varT));
}

INSTANTIATE_TEST_SUITE_P(Isotropic, SlabMultiple,
                         ::testing::Values(SlabCase{1.0f, 0.9f, 0.0f}, SlabCase{2.0f, 1.0f, 0.0f}),
                         [](const ::testing::TestParamInfo<SlabCase>& i) {
                             return "tau" + std::to_string(int(i.param.tau0)) + "_albedo" +
                                    std::to_string(int(std::lround(100 * i.param.albedo)));
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
            PixelStats s = renderSlab(c, mu, above, 1, 1024, 5);
            double p = nbHgEval(c.g, float(above ? -mu : mu));
            double exact = above ? c.albedo * p * (1 - std::exp(-c.tau0 * (1 + 1 / mu))) / (1 + mu)
                                 : c.albedo * p * (std::exp(-c.tau0) - std::exp(-c.tau0 / mu)) / (1 - mu);
            double z = (s.mean - exact) / s.standardError;
            std::printf("HG single %s mu %.1f: pt %.6f exact %.6f se %.1e z %+.2f\n", above ? "reflected  " : "transmitted",
                        mu, s.mean, exact, s.standardError, z);
            EXPECT_LT(std::fabs(z), kSigmas);
        }
    }
}
