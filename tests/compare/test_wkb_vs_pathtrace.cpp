// WKB against the path tracer on small homogeneous spheres (issue 4; docs/validation.md).
//
// L1: WKB's single-scattering term and the path tracer's are two estimators of the same
// integral, so they must agree within the path tracer's noise (its variance AOV gives the
// standard error). L2plus and beauty: WKB is an approximation, so the bounds below are its
// *measured model error* on these scenes (docs/validation.md, "Tolerances"), with a margin, not
// noise: the test catches regressions of the model, not its known weakness.
#include "compare/Compare.h"
#include "engine/Renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace nimbus;

namespace {

struct Case {
    const char* name;
    float tau, albedo, g;
    float3 camera;
    float3 light;  // direction of travel
};

// Light from +z (travelling -z, a little downwards).
const Case kThin = {"thin lit", 1.0f, 0.9f, 0.0f, make_float3(0.8f, 0.6f, 4.0f), make_float3(0, -0.15f, -1)};
const Case kSide = {"mid shadowed", 4.0f, 0.99f, 0.5f, make_float3(3.4f, 0.6f, -2.2f), make_float3(0, -0.15f, -1)};
const Case kBack = {"forward against", 4.0f, 0.95f, 0.9f, make_float3(0.0f, 0.3f, -4.0f), make_float3(0, -0.08f, -1)};

Scene sphereScene(const Case& c, double voxel = 0.08)
{
    Scene s;
    s.camera.width = 32;
    s.camera.height = 32;
    s.camera.from = c.camera;
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 36;
    Volume v;
    v.name = "sphere";
    v.source.type = SourceType::Procedural;
    v.source.generator = "sphere";
    v.source.params = {{"radius", 1.0}, {"voxel_size", voxel}, {"falloff", voxel}};
    const float sigmaT = c.tau / 2.0f;  // tau across the diameter
    v.medium.sigma_s = splat(sigmaT * c.albedo);
    v.medium.sigma_a = splat(sigmaT * (1 - c.albedo));
    v.medium.phase = NbPhase{c.g, 0, 0, 0};
    s.volumes.push_back(v);
    Light sun;
    sun.name = "sun";
    sun.type = LightType::Distant;
    sun.direction = normalize(c.light);
    sun.irradiance = splat(3.0f);
    s.lights.push_back(sun);
    s.render.maxDepth = 1000;
    // A one-pixel box: these tests compare the terms, and the z-tests below count only the path
    // tracer's noise; a wider filter adds WKB's own sampling noise across each pixel's footprint
    // (the filter itself is tested in tests/engine/test_pixel_filter.cpp).
    s.render.pixelFilter = PixelFilter::Box;
    s.render.filterWidth = 1.0f;
    s.output.file = "unused.exr";
    return s;
}

void useTempKernelCache()
{
    setenv("NIMBUS_CACHE_DIR", (std::string(::testing::TempDir()) + "nimbus-kernel-cache-compare").c_str(), 1);
}

double channelMean(const Aov& a, size_t i)
{
    const float* p = a.pixels.data() + i * size_t(a.channels);
    return (p[0] + p[1] + p[2]) / 3.0;
}

// Relative standard error of the image's total beauty (energy), from the variance AOV.
double energyRelSe(const Film& f)
{
    const Aov* v = f.find("variance");
    const Aov* b = f.find("beauty");
    double var = 0, sum = 0;
    for (size_t i = 0; i < size_t(f.width * f.height); ++i)
        var += v->pixels[i], sum += channelMean(*b, i);
    return sum > 0 ? std::sqrt(var) / sum : 0;
}

}  // namespace

// WKB's L1 against the path tracer's with max depth 1 (beauty = L1, the variance AOV is L1's):
// image means within 4 standard errors, and the per-pixel z^2 averaging ~1 (1.5 allows heavy
// tails of the per-pixel variance estimate at 1024 samples). This test found a 0.4% bias in the
// marcher's light cache (it interpolated the convex transmittance between voxels; it now
// interpolates optical depth): z went from +3.8 / +2.6 to +2.5 / +2.0 on these two scenes.
TEST(WkbVsPathtrace, L1WithinPathtracerNoise)
{
    useTempKernelCache();
    for (const Case* c : {&kSide, &kBack}) {
        Scene s = sphereScene(*c, 0.04);
        s.render.method = Method::Wkb;
        s.render.spp = 64;
        RenderResult wkb = render(s);
        s.render.method = Method::Pathtrace;
        s.render.spp = 1024;
        s.render.maxDepth = 1;
        RenderResult pt = render(s);
        const Aov* a = pt.film.find("L1");
        const Aov* b = wkb.film.find("L1");
        const Aov* var = pt.film.find("variance");
        ASSERT_TRUE(a && b && var);
        const int n = s.camera.width * s.camera.height;
        double ptMean = 0, wkbMean = 0, varSum = 0, z2 = 0;
        int pixels = 0;
        for (size_t i = 0; i < size_t(n); ++i) {
            const double p = channelMean(*a, i), q = channelMean(*b, i);
            ptMean += p, wkbMean += q, varSum += var->pixels[i];
            if (var->pixels[i] > 0)
                z2 += (p - q) * (p - q) / var->pixels[i], ++pixels;
        }
        ptMean /= n, wkbMean /= n;
        const double se = std::sqrt(varSum) / n;
        z2 /= std::max(1, pixels);
        std::printf("%s: image mean L1 path tracer %.5f +- %.5f, wkb %.5f (z %+.2f); mean z^2 over %d pixels %.2f\n",
                    c->name, ptMean, se, wkbMean, (wkbMean - ptMean) / se, pixels, z2);
        EXPECT_GT(pixels, 200) << c->name;
        EXPECT_LT(std::fabs(wkbMean - ptMean), 4 * se) << c->name;
        EXPECT_LT(z2, 1.5) << c->name;
    }
}

// L2plus energy and beauty relMSE of WKB (both source models, Gaussian kernel, orders 3+ by the
// kernel: `wkb_orders3` kernel, not the default traced cache, whose orders 3+ tests/compare/
// test_wkb_orders3.cpp checks against the path tracer's) against a 1024-spp full-depth path-traced
// reference. Bounds: docs/validation.md "Tolerances".
// Each bound is the value measured on 2026-11-22 at af4e4c2 (printed by this test) plus a margin: |L2plus
// energy error| <= |measured| + 0.05 (+ 4 reference standard errors), beauty relMSE <= 1.5 x
// measured. WKB is deterministic up to its 16-spp jitter; the margin covers that and the
// reference's noise, and lets an improved model pass.
struct Bound {
    const Case* scene;
    WkbSource source;
    double l2Energy;      // measured relative error of total L2plus energy (WKB model error)
    double beautyRelMse;  // measured beauty relMSE
};

TEST(WkbVsPathtrace, L2plusAndBeautyWithinMeasuredModelError)
{
    useTempKernelCache();
    const Bound bounds[] = {
        {&kThin, WkbSource::Straight, -0.155, 0.0054}, {&kThin, WkbSource::RandomWalk, -0.148, 0.0051},
        {&kSide, WkbSource::Straight, -0.168, 0.030},  {&kSide, WkbSource::RandomWalk, -0.304, 0.066},
        {&kBack, WkbSource::Straight, -0.666, 0.090},  {&kBack, WkbSource::RandomWalk, -0.695, 0.102},
    };
    const Case* last = nullptr;
    Film ref;
    double refSe = 0, refNoise = 0;
    for (const Bound& b : bounds) {
        Scene s = sphereScene(*b.scene);
        if (b.scene != last) {
            s.render.method = Method::Pathtrace;
            s.render.spp = 1024;
            ref = render(s).film;
            refSe = energyRelSe(ref);
            refNoise = referenceNoiseRelMse(ref);
            last = b.scene;
        }
        s.render.method = Method::Wkb;
        s.render.spp = 16;
        s.render.wkbSource = b.source;
        s.render.wkbOrders3 = WkbOrders3::Kernel;  // the bounds are the kernel's measured model error
        RenderResult wkb = render(s);
        const ErrorMetrics l2 = measureError(wkb.film, ref, "L2plus");
        const ErrorMetrics beauty = measureError(wkb.film, ref, "beauty");
        std::printf("%-16s %-11s L2plus energy %+.4f (ref energy SE %.4f), L2plus meanRel %.3f, beauty energy %+.4f, "
                    "beauty relMSE %.4f (ref noise %.5f)\n",
                    b.scene->name, wkbSourceName(b.source), l2.energyRel, refSe, l2.meanRel, beauty.energyRel,
                    beauty.relMse, refNoise);
        EXPECT_LE(std::fabs(l2.energyRel), std::fabs(b.l2Energy) + 0.05 + 4 * refSe)
            << b.scene->name << " " << wkbSourceName(b.source);
        EXPECT_LE(beauty.relMse, 1.5 * b.beautyRelMse) << b.scene->name << " " << wkbSourceName(b.source);
    }
}
