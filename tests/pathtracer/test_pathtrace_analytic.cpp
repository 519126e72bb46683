// The path tracer against scenes with closed-form answers: Skanberg's single-scattering box
// (eq. 44), Beer-Lambert through a purely absorbing medium, white furnaces (albedo 1, and
// absorption balanced by emission) and emission in empty space. Every tolerance is a multiple
// of the standard error the render itself estimates (STYLE rule 14).
#include "PtWorld.h"

#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

constexpr double kSigmas = 4.0;  // |estimate - exact| < 4 standard errors: p ~ 6e-5 per check

void expectWithinNoise(double estimate, double exact, double standardError, const char* what, int channel)
{
    EXPECT_LT(std::fabs(estimate - exact), kSigmas * standardError)
        << what << " channel " << channel << ": estimate " << estimate << " exact " << exact << " standard error "
        << standardError << " z = " << (estimate - exact) / standardError;
    std::printf("%s[%d]: %.6f exact %.6f se %.2e z %+.2f\n", what, channel, estimate, exact, standardError,
                (estimate - exact) / standardError);
}

}  // namespace

// Skanberg sec. 7.1: a homogeneous box lit from above by a distant light, seen from the side,
// single scattering only. Along a horizontal view ray at depth d below the lit face, through
// thickness t:  L = sigma_s p(90 deg) E e^{-sigma_t d} (1 - e^{-sigma_t t}) / sigma_t  (eq. 44).
// RGB coefficients differ per channel, so this also checks spectral tracking at max depth 1.
TEST(PathtraceAnalytic, SkanbergBoxEq44)
{
    useTestKernelCache("analytic");
    const Rgb sigma_s = make_float3(0.5f, 1.0f, 1.5f), sigma_a = make_float3(0.5f, 0.2f, 0.1f);
    const float g = 0.4f, depth = 0.5f, thickness = 1.0f;
    const Rgb E = make_float3(2.0f, 1.0f, 0.5f);
    World w(8, 8);
    // Box x in [-4, 4] (wide: the light path never leaves through a side), y in [-2, 0] (lit
    // face y = 0), z in [-0.5, 0.5] (the view ray's thickness).
    w.volumes.push_back(boxVolume(make_float3(-4, -2, -0.5f), make_float3(4, 0, 0.5f), {2, 2, 2},
                                  medium(sigma_s, sigma_a, NbPhase{g, 0, 0, 0})));
    w.addLight(distantLight(make_float3(0, -1, 0), E));
    // From 50 m with a 0.02 degree field of view the rays span +-9 mm: the depth varies by
    // that much across the image, symmetrically, a second-order change of ~1e-5 relative.
    lookAt(w.scene, make_float3(0, -depth, 50), make_float3(0, -depth, 0), 0.02f);
    w.scene.render.maxDepth = 1;
    w.scene.render.spp = 2048;
    w.scene.render.seed = 3;
    Film f = w.render();

    const double p = nbHgEval(g, 0.0f);  // light travels along -y, leaves along +z: cos = 0
    for (int c = 0; c < 3; ++c) {
        double ss = component(sigma_s, c), st = ss + component(sigma_a, c);
        double exact = ss * p * component(E, c) * std::exp(-st * depth) * (1 - std::exp(-st * thickness)) / st;
        PixelStats s = pixelStats(f, "beauty", c);
        expectWithinNoise(s.mean, exact, s.standardError, "eq44 beauty", c);
        PixelStats l = pixelStats(f, "light_0", c);
        EXPECT_EQ(l.mean, pixelStats(f, "L1", c).mean);
        EXPECT_EQ(pixelStats(f, "L2plus", c).mean, 0.0);
        EXPECT_EQ(pixelStats(f, "L0", c).mean, 0.0);
    }
    // The variance AOV predicts the scatter between pixels.
    double fromAov = standardErrorFromVarianceAov(f);
    double avgMean = 0, avgSs = 0;
    std::vector<double> avg;
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x)
            avg.push_back(nbAverage(pixel3(f, "beauty", x, y)));
    for (double v : avg)
        avgMean += v / avg.size();
    for (double v : avg)
        avgSs += (v - avgMean) * (v - avgMean);
    double fromSpread = std::sqrt(avgSs / (avg.size() - 1)) / std::sqrt(double(avg.size()));
    std::printf("standard error of the image mean: variance AOV %.3e, pixel scatter %.3e\n", fromAov, fromSpread);
    // 64 pixels: the scatter's own relative error is ~1/sqrt(2 * 63) = 9%; allow 4 of those.
    EXPECT_NEAR(fromAov / fromSpread, 1.0, 0.36);
}

// Beer-Lambert: a purely absorbing box whose density ramps linearly along the view axis (so the
// trilinear field is exactly linear and tau = sigma_a * mean density * length). Beauty must be
// background * exp(-tau) per channel, alpha 1 - the channel average of exp(-tau). The loose
// majorant (the ramp's maximum) turns the free-flight weights into ratio tracking.
TEST(PathtraceAnalytic, BeerLambertRamp)
{
    useTestKernelCache("analytic");
    const Rgb sigma_a = make_float3(0.5f, 1.0f, 2.0f), bg = make_float3(1.0f, 2.0f, 3.0f);
    const float length = 1.0f;
    World w(8, 8);
    w.volumes.push_back(boxVolume(make_float3(-1, -1, 0), make_float3(1, 1, length), {2, 2, 2},
                                  medium(splat(0.0f), sigma_a), [](float3 u) { return 0.2f + 0.8f * u.z; }));
    w.scene.background = bg;
    lookAt(w.scene, make_float3(0, 0, 50), make_float3(0, 0, 0), 0.05f);
    w.scene.render.spp = 1024;
    Film f = w.render();
    double tAvg = 0;
    for (int c = 0; c < 3; ++c) {
        double T = std::exp(-component(sigma_a, c) * 0.6 * length);
        tAvg += T / 3;
        PixelStats s = pixelStats(f, "beauty", c);
        expectWithinNoise(s.mean, component(bg, c) * T, s.standardError, "beer-lambert ramp", c);
        EXPECT_EQ(pixelStats(f, "L1", c).mean, 0.0);
    }
    PixelStats a = pixelStats(f, "alpha", 0);
    expectWithinNoise(a.mean, 1.0 - tAvg, a.standardError, "beer-lambert alpha", 0);
}

// The same with a homogeneous medium: the majorant equals sigma_t in the densest channel,
// whose estimate becomes the binary "did the ray get through" of delta tracking, while the
// other channels stay ratio-tracking estimates. Still unbiased: within noise.
TEST(PathtraceAnalytic, BeerLambertHomogeneousChromatic)
{
    useTestKernelCache("analytic");
    const Rgb sigma_a = make_float3(0.25f, 0.5f, 1.0f), bg = make_float3(1.0f, 1.0f, 1.0f);
    World w(8, 8);
    w.volumes.push_back(
        boxVolume(make_float3(-1, -1, -1), make_float3(1, 1, 1), {1, 1, 1}, medium(splat(0.0f), sigma_a)));
    w.scene.background = bg;
    lookAt(w.scene, make_float3(0, 0, 50), make_float3(0, 0, 0), 0.05f);
    w.scene.render.spp = 1024;
    Film f = w.render();
    for (int c = 0; c < 3; ++c) {
        PixelStats s = pixelStats(f, "beauty", c);
        expectWithinNoise(s.mean, std::exp(-2.0 * component(sigma_a, c)), s.standardError, "beer-lambert homogeneous",
                          c);
    }
}

namespace {

// Densities for the furnaces: smooth, positive, far from constant.
float cloudDensity(float3 u)
{
    return 0.3f + 0.7f * (0.5f + 0.5f * std::sin(6 * u.x) * std::cos(5 * u.y) * std::sin(4 * u.z + 1));
}

// Two overlapping volumes with different RGB coefficients and phase functions (HG, two-lobe HG).
void addFurnaceVolumes(World& w, Rgb sigma_s1, Rgb sigma_a1, Rgb sigma_s2, Rgb sigma_a2)
{
    w.volumes.push_back(boxVolume(make_float3(-1, -1, -1), make_float3(1, 1, 1), {2, 2, 2},
                                  medium(sigma_s1, sigma_a1, NbPhase{0.6f, 0, 0, 0}), cloudDensity));
    w.volumes.push_back(boxVolume(make_float3(-0.5f, -1, -0.8f), make_float3(1.5f, 0.5f, 1.2f), {1, 1, 1},
                                  medium(sigma_s2, sigma_a2, NbPhase{0.8f, -0.5f, 0.3f, 0}),
                                  [](float3 u) { return u.x; }));
}

void expectFurnace(const Film& f, Rgb L, const char* what)
{
    for (int c = 0; c < 3; ++c) {
        PixelStats s = pixelStats(f, "beauty", c);
        expectWithinNoise(s.mean, component(L, c), s.standardError, what, c);
    }
}

}  // namespace

// White furnace: albedo 1 everywhere, uniform environment radiance L. L everywhere solves the
// RTE for any density field, any phase function and any boundary, so every pixel must be L,
// seen from outside the volumes and from inside. Exercises spectral tracking (RGB sigma_s),
// overlapping volumes with different phase functions, NEE to the environment with ratio
// tracking, and the absence of double counting (escaped scattered rays add nothing).
TEST(PathtraceAnalytic, WhiteFurnaceChromaticOverlapping)
{
    useTestKernelCache("analytic");
    const Rgb L = make_float3(1.0f, 0.7f, 0.4f);
    World w(12, 12);
    addFurnaceVolumes(w, make_float3(1.0f, 2.0f, 3.0f), splat(0.0f), make_float3(2.0f, 1.0f, 0.5f), splat(0.0f));
    w.addLight(environmentLight(L));
    w.scene.render.maxDepth = 100000;
    w.scene.render.spp = 256;
    lookAt(w.scene, make_float3(0.3f, 0.2f, 4), make_float3(0, 0, 0), 30);
    expectFurnace(w.render(), L, "furnace outside");
    lookAt(w.scene, make_float3(0.1f, -0.2f, 0.3f), make_float3(1, 0.5f, -1), 60);
    expectFurnace(w.render(), L, "furnace inside");
}

// Kirchhoff's furnace: absorption balanced by emission. With emission j = sigma_a L (per
// channel, per point) and a uniform environment L, L everywhere is again the solution. The
// emission grid holds j / 2 and the medium's emission scale is 2, so the scale is tested too.
TEST(PathtraceAnalytic, EmissionAbsorptionFurnace)
{
    useTestKernelCache("analytic");
    const Rgb L = make_float3(0.5f, 1.0f, 1.5f);
    const Rgb sigma_s = make_float3(1.0f, 2.0f, 0.5f), sigma_a = make_float3(1.0f, 0.5f, 2.0f);
    World w(12, 12);
    Medium m = medium(sigma_s, sigma_a, NbPhase{0.3f, 0, 0, 0});
    m.emissionScale = 2.0f;
    w.volumes.push_back(boxVolume(make_float3(-1, -1, -1), make_float3(1, 1, 1), {2, 2, 2}, m, cloudDensity,
                                  [&](float3 u) { return sigma_a * L * (0.5f * cloudDensity(u)); }));
    w.addLight(environmentLight(L));
    w.scene.render.maxDepth = 100000;
    w.scene.render.spp = 256;
    lookAt(w.scene, make_float3(0.3f, 0.2f, 4), make_float3(0, 0, 0), 30);
    expectFurnace(w.render(), L, "kirchhoff furnace");
}

// Emission where the density is zero: a box emitting j uniformly whose density is non-zero only
// in its back third (voxels along z: 0 up to k = 15, ramping to 1 at k = 16 and beyond). The
// camera looks down the z axis: L0 = int_0^Z j T(s) ds by quadrature of the exact piecewise-
// linear density. Tentative collisions in the empty, emitting part come from the emission rate
// of the majorant, not from sigma_t.
TEST(PathtraceAnalytic, EmissionInEmptySpace)
{
    useTestKernelCache("analytic");
    const Rgb j = make_float3(0.3f, 0.6f, 0.9f);
    const float sigma_a = 1.5f, depth = 3.0f;  // box z in [0, 3): 24 voxels of 0.125 m
    auto voxelDensity = [](int k) { return k >= 16 ? 1.0f : 0.0f; };
    World w(8, 8);
    w.volumes.push_back(boxVolume(
        make_float3(-1, -1, 0), make_float3(1, 1, depth), {2, 2, 3}, medium(splat(0.0f), splat(sigma_a)),
        [&](float3 u) { return voxelDensity(int(std::lround(u.z * 24))); }, [&](float3) { return j; }));
    // The camera looks along -z from the empty end: z = 3 is the far side of the density.
    lookAt(w.scene, make_float3(0, 0, -50), make_float3(0, 0, 0), 0.05f);
    w.scene.render.spp = 4096;
    Film f = w.render();
    // int T ds over the three stretches (index units k, voxel v metres): empty k in [0, 15)
    // (T = 1); the ramp k in [15, 16) where tau = sigma_a v s^2 / 2 (a Gaussian integral);
    // density 1 for k in [16, 24) after tau = sigma_a v / 2.
    const double v = depth / 24.0, a = sigma_a * v / 2;
    const double integral = 15 * v + v * std::sqrt(M_PI / (4 * a)) * std::erf(std::sqrt(a)) +
                            std::exp(-a) * (1 - std::exp(-8 * sigma_a * v)) / sigma_a;
    for (int c = 0; c < 3; ++c) {
        PixelStats s = pixelStats(f, "L0", c);
        expectWithinNoise(s.mean, component(j, c) * integral, s.standardError, "emission in empty space", c);
    }
}

// A point light inside a homogeneous HG medium, single scattering along one camera ray, against
// quadrature of  int T(s) sigma_s p(cos) I e^{-sigma_t r(s)} / r(s)^2 ds. NEE's transmittance
// stops at the light (ratio tracking over a finite segment), and the phase function is taken at
// cos = dot(toward light, ray direction): light arrives along -wi and leaves toward the camera.
TEST(PathtraceAnalytic, PointLightInMediumMatchesQuadrature)
{
    useTestKernelCache("analytic");
    const float half = 2.0f, ss = 0.4f, sa = 0.1f, g = 0.5f, I = 5.0f;
    const float3 bulb = make_float3(0.1f, 0.3f, 0.2f);
    World w(4, 4);
    w.volumes.push_back(boxVolume(make_float3(-half, -half, -half), make_float3(half, half, half), {2, 2, 2},
                                  medium(splat(ss), splat(sa), NbPhase{g, 0, 0, 0})));
    Light l;
    l.type = LightType::Point;
    l.position = bulb;
    l.intensity = splat(I);
    w.addLight(l);
    lookAt(w.scene, make_float3(0, 0, 10), make_float3(0, 0, 0), 0.001f);
    w.scene.render.maxDepth = 1;
    w.scene.render.spp = 4096;
    Film f = w.render();

    const double st = ss + sa;
    auto integrand = [&](double s) {
        double z = half - s;  // the ray runs down the z axis from z = 10
        double dx = bulb.x, dy = bulb.y, dz = bulb.z - z;
        double r2 = dx * dx + dy * dy + dz * dz, r = std::sqrt(r2);
        double cosTheta = -dz / r;  // dot(toward the light, (0, 0, -1))
        return std::exp(-st * s) * ss * nbHgEval(g, float(cosTheta)) * I * std::exp(-st * r) / r2;
    };
    // Adaptive Gauss-Kronrod; the integrand is smooth (closest approach 0.32 m) and evaluates HG in
    // float, so its relative error target is a few float ulp.
    const double exact =
        boost::math::quadrature::gauss_kronrod<double, 61>::integrate(integrand, 0.0, 2.0 * half, 15, 8 * FLT_EPSILON);
    PixelStats s = pixelStats(f, "L1", 0);
    expectWithinNoise(s.mean, exact, s.standardError, "point light in medium", 0);
}
