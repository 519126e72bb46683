// The path tracer's L1 against the single-scattering integrator's on a heterogeneous procedural
// cloud, through the public API (render(): JSON-free Scene -> buildVolumes -> both methods).
// Two independent estimators of the same integral (eq. 31 of Tessendorf): a ray march with deep
// shadow maps, and delta tracking with ratio-tracked NEE.
#include "engine/Renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace nimbus;

namespace {

Scene cloudScene(float g)
{
    Scene s;
    s.camera.width = 24;
    s.camera.height = 18;
    s.camera.from = make_float3(0.3f, 0.4f, 4.5f);
    s.camera.to = make_float3(0, 0.0f, 0);
    s.camera.fov = 20;
    Volume v;
    v.name = "cloud";
    v.source.type = SourceType::Procedural;
    v.source.generator = "cloud";
    v.source.params = {{"radius", 0.8}, {"voxel_size", 0.04}, {"seed", 3}};
    v.medium.sigma_s = make_float3(2.5f, 3.0f, 3.5f);
    v.medium.sigma_a = splat(0.3f);
    v.medium.phase = NbPhase{g, 0, 0, 0};
    s.volumes.push_back(v);
    Light sun;
    sun.name = "sun";
    sun.type = LightType::Distant;
    sun.direction = normalize(make_float3(0.5f, -1.0f, -0.4f));
    sun.irradiance = splat(2.0f);
    s.lights.push_back(sun);
    Light bulb;
    bulb.name = "bulb";
    bulb.type = LightType::Point;
    bulb.position = make_float3(-1.5f, 0.5f, 1.5f);
    bulb.intensity = splat(3.0f);
    s.lights.push_back(bulb);
    s.output.file = "unused.exr";
    return s;
}

struct Comparison {
    double ptMean = 0, singleMean = 0, standardError = 0, chi2PerPixel = 0;
    int pixels = 0;
};

Comparison compareL1(float g)
{
    setenv("NIMBUS_CACHE_DIR", (std::string(::testing::TempDir()) + "nimbus-kernel-cache-vs-single").c_str(), 1);
    Scene s = cloudScene(g);
    s.render.method = Method::Single;
    s.render.spp = 1024;  // its pixel-jitter noise then stays well below the path tracer's
    RenderResult single = render(s);
    s.render.method = Method::Pathtrace;
    s.render.spp = 1024;
    s.render.maxDepth = 1;
    RenderResult pt = render(s);

    // With max depth 1, no emission and a black background, beauty is L1: the variance AOV is
    // L1's (channel average).
    const Aov* a = pt.film.find("L1");
    const Aov* b = single.film.find("L1");
    const Aov* var = pt.film.find("variance");
    Comparison c;
    double varSum = 0;
    for (int i = 0; i < s.camera.width * s.camera.height; ++i) {
        double p = (a->pixels[3 * i] + a->pixels[3 * i + 1] + a->pixels[3 * i + 2]) / 3;
        double q = (b->pixels[3 * i] + b->pixels[3 * i + 1] + b->pixels[3 * i + 2]) / 3;
        c.ptMean += p;
        c.singleMean += q;
        varSum += var->pixels[size_t(i)];
        if (var->pixels[size_t(i)] > 0) {
            c.chi2PerPixel += (p - q) * (p - q) / var->pixels[size_t(i)];
            ++c.pixels;
        }
    }
    const int n = s.camera.width * s.camera.height;
    c.ptMean /= n;
    c.singleMean /= n;
    c.standardError = std::sqrt(varSum) / n;
    c.chi2PerPixel /= std::max(1, c.pixels);
    std::printf("g %.1f: image mean L1 path tracer %.5f +- %.5f, single %.5f (z %+.2f); mean z^2 over %d pixels %.2f\n",
                g, c.ptMean, c.standardError, c.singleMean, (c.singleMean - c.ptMean) / c.standardError, c.pixels,
                c.chi2PerPixel);
    return c;
}

}  // namespace

// Isotropic scattering. The single integrator's own error (deep-shadow-map tolerance 0.2% of
// transmittance, jittered march) is well below the path tracer's noise per pixel, so the
// per-pixel z^2 must average ~1 (for ~400 pixels its standard deviation is ~0.07; 1.5 allows the
// heavier tails of 1024-sample means), and the image means agree within 4 standard errors plus
// the shadow maps' 0.2%.
TEST(PathtraceVsSingle, L1AgreesOnHeterogeneousCloud)
{
    Comparison c = compareL1(0.0f);
    EXPECT_GT(c.pixels, 200);
    EXPECT_LT(std::fabs(c.ptMean - c.singleMean), 4 * c.standardError + 0.002 * c.ptMean);
    EXPECT_LT(c.chi2PerPixel, 1.5);
}
