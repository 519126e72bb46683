// Equi-angular sampling in the path tracer (render.equiangular, docs/pathtracer.md "Equi-angular
// sampling"): unbiased against the path tracer without it and against quadrature of the single
// scattering integral, on a point light inside a haze box, a point light outside a sphere, a spot
// light, a chromatic medium and a heterogeneous two-volume cloud.
//
// Probes: a camera with a field of view of 0.001 degrees sees one ray in every pixel, so the
// pixels are independent estimates of one value and their scatter gives the standard error of
// each AOV and channel (L1 and L2plus separately). Each probe is rendered with and without
// equi-angular sampling (different seeds) and the means are compared by z = diff / sqrt(se_on^2 +
// se_off^2), |z| < 4. Without equi-angular sampling the NEE at vertices near a point light has
// infinite variance (int r^-4 r^2 dr diverges), which is what this estimator removes; the mean is
// still finite and the self-normalised z stays a fair test.
#include "PtWorld.h"

#include <boost/math/quadrature/gauss_kronrod.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

constexpr int kProbePixels = 8;

Film renderProbe(World& w, float3 from, float3 to, bool equi, uint32_t seed, int spp)
{
    lookAt(w.scene, from, to, 0.001f);
    w.scene.render.equiangular = equi;
    w.scene.render.seed = seed;
    w.scene.render.spp = spp;
    return w.render();
}

// |z| < 4 between the two renders for each channel of `aov`; returns the largest |z|.
double expectSameMeans(const Film& on, const Film& off, const std::string& aov, const std::string& what)
{
    double worst = 0;
    for (int c = 0; c < 3; ++c) {
        const PixelStats a = pixelStats(on, aov, c), b = pixelStats(off, aov, c);
        const double se = std::sqrt(a.standardError * a.standardError + b.standardError * b.standardError);
        if (se == 0) {
            EXPECT_EQ(a.mean, b.mean) << what << " " << aov << " channel " << c;
            continue;
        }
        const double z = (a.mean - b.mean) / se;
        std::printf("%s %s[%d]: equi %.6g +- %.2g, distance only %.6g +- %.2g, z %+.2f\n", what.c_str(), aov.c_str(),
                    c, a.mean, a.standardError, b.mean, b.standardError, z);
        EXPECT_LT(std::fabs(z), 4.0) << what << " " << aov << " channel " << c << ": equi " << a.mean << " +- "
                                     << a.standardError << ", distance only " << b.mean << " +- " << b.standardError;
        worst = std::max(worst, std::fabs(z));
    }
    return worst;
}

// One probe ray rendered both ways; L1 and L2plus compared per channel.
void compareProbe(World& w, float3 from, float3 to, int spp, const std::string& what)
{
    const Film on = renderProbe(w, from, to, true, 101, spp);
    const Film off = renderProbe(w, from, to, false, 202, spp);
    expectSameMeans(on, off, "L1", what);
    expectSameMeans(on, off, "L2plus", what);
}

World hazeBox(Rgb sigma_s, Rgb sigma_a, NbPhase phase)
{
    World w(kProbePixels, kProbePixels);
    w.volumes.push_back(
        boxVolume(make_float3(-2, -2, -2), make_float3(2, 2, 2), {2, 2, 2}, medium(sigma_s, sigma_a, phase)));
    return w;
}

Light pointLight(float3 position, Rgb intensity)
{
    Light l;
    l.type = LightType::Point;
    l.position = position;
    l.intensity = intensity;
    return l;
}

// Single scattering of a point light inside the homogeneous box [-half, half]^3 seen along the
// ray from `from` towards `to`, per channel: int sigma_s e^(-sigma_t s) p I e^(-sigma_t r) / r^2
// over the ray's stretch inside the box (the light is inside and the box convex, so the light
// ray stays inside too). Adaptive Gauss-Kronrod split at the foot of the perpendicular.
double singleScatteringQuadrature(float3 from, float3 to, double half, double ss, double st, float g, float3 bulb,
                                  double I)
{
    const double o[3] = {from.x, from.y, from.z};
    double d[3] = {to.x - from.x, to.y - from.y, to.z - from.z};
    const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (double& x : d)
        x /= len;
    double t0 = 0, t1 = 1e30;
    for (int a = 0; a < 3; ++a) {
        double ta = (-half - o[a]) / d[a], tb = (half - o[a]) / d[a];
        t0 = std::max(t0, std::min(ta, tb));
        t1 = std::min(t1, std::max(ta, tb));
    }
    const double c[3] = {bulb.x, bulb.y, bulb.z};
    auto integrand = [&](double t) {
        double p[3], wi[3], r2 = 0;
        for (int a = 0; a < 3; ++a) {
            p[a] = o[a] + t * d[a];
            wi[a] = c[a] - p[a];
            r2 += wi[a] * wi[a];
        }
        const double r = std::sqrt(r2);
        const double cosTheta = (wi[0] * d[0] + wi[1] * d[1] + wi[2] * d[2]) / r;
        return ss * std::exp(-st * (t - t0)) * nbHgEval(g, float(cosTheta)) * I * std::exp(-st * r) / r2;
    };
    double foot = 0;
    for (int a = 0; a < 3; ++a)
        foot += (c[a] - o[a]) * d[a];
    foot = std::min(t1, std::max(t0, foot));
    using GK = boost::math::quadrature::gauss_kronrod<double, 61>;
    double sum = 0;
    if (foot > t0)
        sum += GK::integrate(integrand, t0, foot, 20, 8 * FLT_EPSILON);
    if (t1 > foot)
        sum += GK::integrate(integrand, foot, t1, 20, 8 * FLT_EPSILON);
    return sum;
}

}  // namespace

// A point light inside a 4 m haze box, max depth 1: L1 along a ray passing 3 cm from the light and
// one passing 1 m from it equals quadrature with and without equi-angular sampling, and near the
// light equi-angular sampling cuts the standard error at equal samples (the fireflies it removes).
TEST(PathtraceEquiangular, HazeBoxSingleScatteringMatchesQuadrature)
{
    useTestKernelCache("equiangular");
    const float ss = 0.3f, sa = 0.05f, g = 0.3f, I = 10.0f;
    const float3 bulb = make_float3(0.3f, 0.2f, -0.4f);
    World w = hazeBox(splat(ss), splat(sa), NbPhase{g, 0, 0, 0});
    w.addLight(pointLight(bulb, splat(I)));
    w.scene.render.maxDepth = 1;
    const float3 from = make_float3(0, 0, 10);
    struct Ray {
        const char* name;
        float3 offset;
    } rays[] = {{"3 cm from the light", make_float3(0.03f, 0, 0)}, {"1 m from the light", make_float3(0, 1.0f, 0)}};
    for (const Ray& ray : rays) {
        const float3 to = bulb + ray.offset;
        const double exact = singleScatteringQuadrature(from, to, 2.0, ss, ss + sa, g, bulb, I);
        const Film on = renderProbe(w, from, to, true, 11, 1024);
        const Film off = renderProbe(w, from, to, false, 12, 1024);
        const PixelStats a = pixelStats(on, "L1", 0), b = pixelStats(off, "L1", 0);
        std::printf("%s: quadrature %.6g, equi %.6g +- %.2g (z %+.2f), distance only %.6g +- %.2g (z %+.2f)\n",
                    ray.name, exact, a.mean, a.standardError, (a.mean - exact) / a.standardError, b.mean,
                    b.standardError, (b.mean - exact) / b.standardError);
        EXPECT_LT(std::fabs(a.mean - exact), 4 * a.standardError) << ray.name << ": equi-angular";
        EXPECT_LT(std::fabs(b.mean - exact), 4 * b.standardError) << ray.name << ": distance sampling only";
        if (ray.offset.x > 0) {
            // The tracking NEE's relative variance per sample along a ray at h from a point light
            // grows like 1 / (sigma_t h) (18 here); equi-angular's is bounded: at least 2x (in
            // practice ~10x) smaller standard error.
            EXPECT_LT(a.standardError, 0.5 * b.standardError) << ray.name;
        }
    }
}

// The same box, all orders: L1 and L2plus agree with and without equi-angular sampling.
TEST(PathtraceEquiangular, PointLightInsideHazeBoxUnbiased)
{
    useTestKernelCache("equiangular");
    const float3 bulb = make_float3(0.3f, 0.2f, -0.4f);
    World w = hazeBox(splat(0.3f), splat(0.05f), NbPhase{0.3f, 0, 0, 0});
    w.addLight(pointLight(bulb, splat(10.0f)));
    compareProbe(w, make_float3(0, 0, 10), bulb + make_float3(0.03f, 0, 0), 1024, "haze, 3 cm");
    compareProbe(w, make_float3(0, 0, 10), bulb + make_float3(0, 1.0f, 0), 1024, "haze, 1 m");
}

// A point light 0.12 m outside a dense sphere of radius 0.9 m (soft-edged density in a box): the
// equi-angular segment is the box's stretch of the ray. The edge probe passes 0.17 m from the
// light, where equi-angular sampling is taken (nbEquiWorthwhile: its pdf's peak 2.1/m against
// half the majorant, 1.65/m); through the centre it is not.
TEST(PathtraceEquiangular, PointLightOutsideSphereUnbiased)
{
    useTestKernelCache("equiangular");
    World w(kProbePixels, kProbePixels);
    w.volumes.push_back(boxVolume(make_float3(-1, -1, -1), make_float3(1, 1, 1), {2, 2, 2},
                                  medium(splat(3.0f), splat(0.3f), NbPhase{0.6f, 0, 0, 0}), [](float3 u) {
                                      const float3 c = u - make_float3(0.5f, 0.5f, 0.5f);
                                      return dot(c, c) < 0.45f * 0.45f ? 1.0f : 0.0f;
                                  }));
    w.addLight(pointLight(make_float3(1.02f, 0.0f, 0.0f), splat(6.0f)));
    compareProbe(w, make_float3(0.85f, 0, 10), make_float3(0.85f, 0, 0), 1024, "sphere, edge near the light");
    compareProbe(w, make_float3(0.3f, 0, 10), make_float3(0, 0, 0), 1024, "sphere, centre");
}

// A spot light in haze: a ray grazing under the apex (the cone is mostly missed: equi-angular
// points outside it add nothing) and one crossing the cone and its soft edge lower down.
TEST(PathtraceEquiangular, SpotLightUnbiased)
{
    useTestKernelCache("equiangular");
    World w = hazeBox(splat(0.4f), splat(0.05f), NbPhase{0.5f, 0, 0, 0});
    Light spot;
    spot.type = LightType::Spot;
    spot.position = make_float3(0, 1.5f, 0);
    spot.direction = make_float3(0, -1, 0);
    spot.intensity = splat(20.0f);
    spot.coneAngle = 40.0f;
    spot.coneSoftness = 5.0f;
    w.addLight(spot);
    compareProbe(w, make_float3(0, 1.45f, 10), make_float3(0, 1.45f, 0), 1024, "spot, under the apex");
    compareProbe(w, make_float3(-3, -0.5f, 10), make_float3(0.3f, -0.5f, 0), 1024, "spot, across the cone");
}

// RGB coefficients (spectral tracking's history-aware probabilities) and a backward phase
// function: per channel, L1 against quadrature at max depth 1, and all orders both ways.
TEST(PathtraceEquiangular, ChromaticMediumUnbiased)
{
    useTestKernelCache("equiangular");
    const Rgb ss = make_float3(0.2f, 0.5f, 0.9f), sa = make_float3(0.1f, 0.02f, 0.05f), I = make_float3(5, 8, 12);
    const float g = -0.3f;
    const float3 bulb = make_float3(-0.2f, 0.1f, 0.3f);
    World w = hazeBox(ss, sa, NbPhase{g, 0, 0, 0});
    w.addLight(pointLight(bulb, I));
    const float3 from = make_float3(0, 0, 10), to = bulb + make_float3(0.05f, 0, 0);
    compareProbe(w, from, to, 1024, "chromatic, 5 cm");

    w.scene.render.maxDepth = 1;
    const Film on = renderProbe(w, from, to, true, 31, 1024);
    for (int c = 0; c < 3; ++c) {
        const double exact = singleScatteringQuadrature(from, to, 2.0, component(ss, c), component(ss + sa, c), g, bulb,
                                                        component(I, c));
        const PixelStats a = pixelStats(on, "L1", c);
        std::printf("chromatic L1[%d]: quadrature %.6g, equi %.6g +- %.2g (z %+.2f)\n", c, exact, a.mean,
                    a.standardError, (a.mean - exact) / a.standardError);
        EXPECT_LT(std::fabs(a.mean - exact), 4 * a.standardError) << "channel " << c;
    }
}

// A heterogeneous cloud of two overlapping volumes (RGB, HG g 0.7 and a two-lobe HG: the
// equi-angular point's in-scattering sums both phase functions), a point light inside it and a
// sun (which equi-angular sampling leaves alone).
TEST(PathtraceEquiangular, HeterogeneousCloudUnbiased)
{
    useTestKernelCache("equiangular");
    World w(kProbePixels, kProbePixels);
    w.volumes.push_back(boxVolume(
        make_float3(-1.5f, -1.5f, -1.5f), make_float3(1.5f, 1.5f, 1.5f), {3, 3, 3},
        medium(make_float3(2.0f, 2.4f, 2.8f), splat(0.2f), NbPhase{0.7f, 0, 0, 0}), [](float3 u) {
            const float3 c = u - make_float3(0.5f, 0.5f, 0.5f);
            const float falloff = std::max(0.0f, 1.0f - 4.0f * dot(c, c));
            return falloff * (0.5f + 0.5f * std::sin(14 * u.x) * std::sin(10 * u.y) * std::cos(12 * u.z));
        }));
    w.volumes.push_back(boxVolume(make_float3(-0.5f, -0.5f, -0.5f), make_float3(1.2f, 1.0f, 0.8f), {1, 1, 1},
                                  medium(splat(1.0f), splat(0.3f), NbPhase{0.8f, -0.3f, 0.25f, 0}),
                                  [](float3 u) { return u.y; }));
    const float3 bulb = make_float3(0.2f, 0.1f, 0.2f);
    w.addLight(pointLight(bulb, splat(4.0f)));
    w.addLight(distantLight(make_float3(0.4f, -1, -0.3f), splat(1.5f)));
    compareProbe(w, make_float3(0, 0, 10), bulb + make_float3(0.04f, 0, 0), 1024, "cloud, 4 cm");
    compareProbe(w, make_float3(0, 0, 10), make_float3(-0.8f, -0.6f, 0), 1024, "cloud, away from the light");
}

// The whole image of the haze box with the light in view: the beauty's image mean agrees within
// the noise of the two renders' variance AOVs.
TEST(PathtraceEquiangular, HazeBoxImageMeanUnbiased)
{
    useTestKernelCache("equiangular");
    World w = hazeBox(splat(0.3f), splat(0.05f), NbPhase{0.3f, 0, 0, 0});
    w.scene.camera.width = w.scene.camera.height = 16;
    w.addLight(pointLight(make_float3(0.3f, 0.2f, -0.4f), splat(10.0f)));
    lookAt(w.scene, make_float3(0, 0, 10), make_float3(0, 0, 0), 26);
    w.scene.render.spp = 256;
    double mean[2] = {0, 0}, var[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
        w.scene.render.equiangular = k == 0;
        w.scene.render.seed = 41 + k;
        const Film f = w.render();
        const int n = f.width * f.height;
        for (int y = 0; y < f.height; ++y)
            for (int x = 0; x < f.width; ++x) {
                const Rgb b = pixel3(f, "beauty", x, y);
                mean[k] += (b.x + b.y + b.z) / 3 / n;
                var[k] += pixel1(f, "variance", x, y) / (double(n) * n);
            }
    }
    const double z = (mean[0] - mean[1]) / std::sqrt(var[0] + var[1]);
    std::printf("haze image mean: equi %.6g +- %.2g, distance only %.6g +- %.2g, z %+.2f\n", mean[0],
                std::sqrt(var[0]), mean[1], std::sqrt(var[1]), z);
    EXPECT_LT(std::fabs(z), 4.0);
    EXPECT_LT(var[0], var[1]);  // the image's noise falls too
}
