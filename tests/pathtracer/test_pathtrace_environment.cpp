// Environment lights with HDR maps (issue 17, item 1), rendered through the public API:
//  - the sky's L1 from single and wkb (the sky grid, src/render/SkyLight.h) against the path
//    tracer's (the map importance-sampled, MIS with the phase function; kernels/pathtrace.cl);
//  - a map that is one bright texel against the equivalent distant light;
//  - a constant map against the constant-colour environment.
#include "engine/Renderer.h"

#include "../render/EnvMapFiles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace nimbus;

namespace {

void useKernelCache()
{
    setenv("NIMBUS_CACHE_DIR", (std::string(::testing::TempDir()) + "nimbus-kernel-cache-environment").c_str(), 1);
}

Scene cloudScene(float g, Rgb sigma_s, Rgb sigma_a)
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
    v.medium.sigma_s = sigma_s;
    v.medium.sigma_a = sigma_a;
    v.medium.phase = NbPhase{g, 0, 0, 0};
    s.volumes.push_back(v);
    s.output.file = "unused.exr";
    return s;
}

Light environment(const std::string& map, float rotate = 0.0f)
{
    Light l;
    l.name = "sky";
    l.type = LightType::Environment;
    l.map = map;
    l.rotate = rotate;
    return l;
}

// A daylight sky: blue above, brighter toward the horizon on one side, a dark ground; smooth,
// as a sky without its sun is.
std::string skyMap()
{
    const int W = 128, H = 64;
    std::vector<float> rgb(size_t(W * H) * 3);
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            const double v = (j + 0.5) / H, u = (i + 0.5) / W;
            const double up = std::cos(M_PI * v);  // w_y
            const double side = 0.5 + 0.5 * std::cos(2 * M_PI * (u - 0.3)) * std::sin(M_PI * v);
            float* t = rgb.data() + 3 * (j * W + i);
            if (up > 0) {
                t[0] = float(0.3 + 0.5 * side * (1 - up)), t[1] = float(0.5 + 0.4 * side * (1 - up)), t[2] = 0.9f;
            } else {
                t[0] = t[1] = t[2] = 0.05f;
            }
        }
    return test::writeEnvMap("sky_gradient.exr", W, H, rgb);
}

// The image mean of the channel average of an AOV.
double aovMean(const RenderResult& r, const char* aov)
{
    const Aov* a = r.film.find(aov);
    EXPECT_TRUE(a) << aov;
    if (!a)
        return 0.0;
    double sum = 0;
    const size_t n = a->pixels.size() / 3;
    for (size_t i = 0; i < n; ++i)
        sum += (a->pixels[3 * i] + a->pixels[3 * i + 1] + a->pixels[3 * i + 2]) / 3.0;
    return sum / double(n);
}

// The path tracer's L1 (max depth 1: beauty is L0 + L1, and the variance AOV is beauty's) and
// the standard error of its image mean. L0 is the same deterministic background in every sample
// of a pixel whose camera ray leaves the volume, so it adds nothing to the variance there.
struct PtL1 {
    double mean = 0, standardError = 0;
};
PtL1 pathtraceL1(Scene s, int spp)
{
    useKernelCache();
    s.render.method = Method::Pathtrace;
    s.render.spp = spp;
    s.render.maxDepth = 1;
    const RenderResult r = render(s);
    PtL1 out;
    out.mean = aovMean(r, "L1");
    const Aov* var = r.film.find("variance");
    double varSum = 0;
    for (float v : var->pixels)
        varSum += v;
    out.standardError = std::sqrt(varSum) / double(var->pixels.size());
    return out;
}

double marchL1(Scene s, Method m)
{
    s.render.method = m;
    s.render.spp = 16;
    const RenderResult r = render(s);
    return aovMean(r, m == Method::Wkb ? "L1" : "L1");
}

}  // namespace

// The sky grid's stated accuracy (docs/single-scattering.md, "environment lights"): the image's
// sky L1 within a + b |g|^3 of the exact single scattering at the default grid (32 nodes across,
// SH order 2, the phase's forward peak and bands above 2 added along the camera ray: SkyTail.h).
// a is what the transmittance's variation within a node's cell and a sky cell leaves; b |g|^3
// would be what the peak's transmittance, taken along the camera ray, leaves as the phase grows
// forward (p_3 = g^3 is the first band left to the march). Both were fitted by
// tests/validation/sky_grid_accuracy.py on seven calibration scenes (other clouds, skies,
// densities, g from -0.5 to 0.9: the smallest a, b >= 0 covering every one after its 2-sigma
// noise allowance): a = 0.0035, b = 0.0354. Judged here on scenes they were not fitted on.
constexpr double kSkyGridA = 0.0035, kSkyGridB = 0.0354;
double skyGridBound(double g)
{
    return kSkyGridA + kSkyGridB * std::fabs(g * g * g);
}

TEST(PathtraceEnvironment, SkyL1OfSingleAndWkbMatchesThePathTracer)
{
    Scene s = cloudScene(0.6f, splat(1.0f), splat(0.1f));
    s.lights.push_back(environment(skyMap(), 40.0f));
    const PtL1 pt = pathtraceL1(s, 1024);
    const double single = marchL1(s, Method::Single), wkb = marchL1(s, Method::Wkb);
    std::printf("sky L1: path tracer %.6f +- %.6f, single %.6f (%+.2f%%), wkb %.6f (%+.2f%%)\n", pt.mean,
                pt.standardError, single, 100 * (single / pt.mean - 1), wkb, 100 * (wkb / pt.mean - 1));
    EXPECT_LT(std::fabs(single - pt.mean), 4 * pt.standardError + skyGridBound(0.6) * pt.mean);
    EXPECT_LT(std::fabs(wkb - pt.mean), 4 * pt.standardError + skyGridBound(0.6) * pt.mean);
}

// The same bound on media thicker than any the constants were fitted on, where the sky's light
// falls off within a mean free path of the surface and the camera sees that first mean free path:
// a homogeneous sphere of 1 and 0.4 mean free paths per voxel (the grid's nodes 1.5 voxels apart)
// under the gradient sky, isotropic and g 0.6. Before the grid's shadow rays marched the
// full-resolution density near their start and its nodes were weighted by what the camera sees,
// single's sky L1 was 33-35% and 12-13% low here (docs/single-scattering.md, "environment light").
TEST(PathtraceEnvironment, SkyL1OfThickMediaMatchesThePathTracer)
{
    for (float sigmaT : {20.0f, 8.0f})
        for (float g : {0.0f, 0.6f}) {
            Scene s = cloudScene(g, splat(0.99f * sigmaT), splat(0.01f * sigmaT));
            Volume& v = s.volumes[0];
            v.source.generator = "sphere";
            v.source.params = {{"radius", 0.8}, {"voxel_size", 0.05}, {"falloff", 0.1}};
            s.lights.push_back(environment(skyMap(), 40.0f));
            const PtL1 pt = pathtraceL1(s, 512);
            const double single = marchL1(s, Method::Single);
            std::printf("sigma_t %.0f, g %.1f: sky L1 path tracer %.6f +- %.6f, single %.6f (%+.2f%%)\n", sigmaT, g,
                        pt.mean, pt.standardError, single, 100 * (single / pt.mean - 1));
            EXPECT_LT(std::fabs(single - pt.mean), 4 * pt.standardError + skyGridBound(g) * pt.mean);
        }
}

// A map black but for one texel of radiance L is a distant light of irradiance L * Omega_texel
// from the texel's centre (to the texel's 1.4 degree extent, far below what the cloud's
// shadows resolve at this voxel size). Path tracer: the map sample finds the texel, the phase
// sample almost never (MIS weights it out); z-test of the two path-traced means. Single's map,
// with isotropic scattering (the sky grid's order 0 is then exact): within the grid's bound of the
// path tracer's, plus four standard errors. (It was held against single's distant light until the
// bound was refitted on 2026-12-06: that difference, +0.4%, holds the sun's shadow map's own error
// too, and the refitted a, 0.35%, bounds the grid's alone.)
TEST(PathtraceEnvironment, OneBrightTexelIsTheEquivalentDistantLight)
{
    const int W = 256, H = 128, ti = 80, tj = 30;
    std::vector<float> rgb(size_t(W * H) * 3, 0.0f);
    const float L = 2000.0f;
    for (int c = 0; c < 3; ++c)
        rgb[size_t(3 * (tj * W + ti) + c)] = L;
    const std::string path = test::writeEnvMap("one_texel.exr", W, H, rgb);
    const EnvironmentMap map(W, H, rgb, 0.0f);
    const float3 toTexel = map.texelDirection(ti, tj);
    const float E = float(L * map.texelSolidAngle(tj));

    for (float g : {0.0f, 0.6f}) {
        Scene sky = cloudScene(g, splat(1.0f), splat(0.1f));
        sky.lights.push_back(environment(path));
        Scene sun = cloudScene(g, splat(1.0f), splat(0.1f));
        Light d;
        d.name = "sun";
        d.type = LightType::Distant;
        d.direction = -toTexel;
        d.irradiance = splat(E);
        sun.lights.push_back(d);
        const PtL1 a = pathtraceL1(sky, 512), b = pathtraceL1(sun, 256);
        const double se = std::hypot(a.standardError, b.standardError);
        std::printf("g %.1f: one-texel map L1 %.6f +- %.6f, distant light %.6f +- %.6f (z %+.2f)\n", g, a.mean,
                    a.standardError, b.mean, b.standardError, (a.mean - b.mean) / se);
        EXPECT_LT(std::fabs(a.mean - b.mean), 4 * se);
        if (g == 0.0f) {
            const double single = marchL1(sky, Method::Single), singleSun = marchL1(sun, Method::Single);
            std::printf("single, g 0: one-texel map %.6f (%+.2f%% against the path tracer's), distant light %.6f "
                        "(%+.2f%%)\n",
                        single, 100 * (single / a.mean - 1), singleSun, 100 * (single / singleSun - 1));
            EXPECT_LT(std::fabs(single - a.mean), 4 * a.standardError + skyGridBound(0.0) * a.mean);
        }
    }
}

// A constant map of value c (intensity 1, radiance 1) is the constant-colour environment c: in
// the path tracer one path samples the map with MIS, the other the phase function alone
// (z-test); single's sky grid is built the same way for both (to float rounding).
TEST(PathtraceEnvironment, ConstantMapEqualsConstantEnvironment)
{
    const Rgb c = make_float3(0.3f, 0.45f, 0.7f);
    const int W = 64, H = 32;
    std::vector<float> rgb(size_t(W * H) * 3);
    for (size_t k = 0; k < rgb.size(); k += 3)
        rgb[k] = c.x, rgb[k + 1] = c.y, rgb[k + 2] = c.z;
    Scene mapped = cloudScene(0.6f, splat(1.0f), splat(0.1f));
    mapped.lights.push_back(environment(test::writeEnvMap("constant.exr", W, H, rgb), 17.0f));
    Scene uniform = cloudScene(0.6f, splat(1.0f), splat(0.1f));
    Light u = environment("");
    u.radiance = c * 0.5f;
    u.mapIntensity = 2.0f;  // radiance * intensity = c
    uniform.lights.push_back(u);
    const PtL1 a = pathtraceL1(mapped, 512), b = pathtraceL1(uniform, 512);
    const double se = std::hypot(a.standardError, b.standardError);
    std::printf("constant map L1 %.6f +- %.6f, constant environment %.6f +- %.6f (z %+.2f)\n", a.mean,
                a.standardError, b.mean, b.standardError, (a.mean - b.mean) / se);
    EXPECT_LT(std::fabs(a.mean - b.mean), 4 * se);
    // Single: the rotated map's sky cells lie at other azimuths than the uniform sky's, two
    // quadratures of one integral (within the grid's bound); unrotated, a map of the uniform
    // sky's own size (SkyLight.cpp: 2 x 16 by 2 x 8 texels) gives the same cells, and the same
    // light to float rounding.
    const double singleMapped = marchL1(mapped, Method::Single), singleUniform = marchL1(uniform, Method::Single);
    std::vector<float> small(size_t(32 * 16) * 3);
    for (size_t k = 0; k < small.size(); k += 3)
        small[k] = c.x, small[k + 1] = c.y, small[k + 2] = c.z;
    Scene same = uniform;
    same.lights[0] = environment(test::writeEnvMap("constant_small.exr", 32, 16, small));
    const double singleSame = marchL1(same, Method::Single);
    std::printf("single: constant map %.6f (rotated), %.6f (unrotated), constant environment %.6f\n", singleMapped,
                singleSame, singleUniform);
    EXPECT_LT(std::fabs(singleMapped - singleUniform), skyGridBound(0.6) * singleUniform);
    EXPECT_NEAR(singleSame, singleUniform, 1e-5 * singleUniform);
    // And both show the colour where camera rays leave the volume (L0: the colour times the
    // camera ray's transmittance): pixel by pixel the same.
    Scene a0 = mapped, b0 = uniform;
    a0.render.method = b0.render.method = Method::Single;
    // Sample for sample: adaptive sampling off (the two skies' L1 differ within the grid's bound,
    // and with them how many samples a pixel would take).
    a0.render.adaptiveThreshold = b0.render.adaptiveThreshold = 0.0;
    const RenderResult ra = render(a0), rb = render(b0);
    const Aov *la = ra.film.find("L0"), *lb = rb.film.find("L0");
    for (size_t k = 0; k < la->pixels.size(); ++k)
        ASSERT_NEAR(la->pixels[k], lb->pixels[k], 1e-5f * std::max(1.0f, lb->pixels[k])) << "L0 value " << k;
}

// Under an environment map, single writes the tiles whose rays cannot meet a volume without
// marching them (TileDriver.cpp, emptyPixel): each sample's ray made as a march makes it, the
// map read along it. wkb marches every tile; its L0 where the rays miss is the same background
// along the same rays, so the two agree bit for bit wherever the pixel's alpha is 0, and the
// frame has such tiles (the cloud fills a quarter of it).
TEST(EnvironmentTiles, EmptyTilesUnderAMapEqualMarchedOnes)
{
    Scene s = cloudScene(0.6f, splat(1.0f), splat(0.1f));
    s.camera.width = 96;
    s.camera.height = 64;
    s.camera.fov = 40;
    s.lights.push_back(environment(skyMap(), 40.0f));
    s.render.spp = 3;
    Scene w = s;
    s.render.method = Method::Single;
    w.render.method = Method::Wkb;
    const RenderResult a = render(s), b = render(w);
    const Aov *la = a.film.find("L0"), *lb = b.film.find("L0"), *alpha = a.film.find("alpha");
    ASSERT_TRUE(la && lb && alpha);
    size_t clear = 0;
    for (size_t p = 0; p < alpha->pixels.size(); ++p) {
        if (alpha->pixels[p] != 0.0f)
            continue;
        ++clear;
        for (int c = 0; c < 3; ++c)
            ASSERT_EQ(la->pixels[3 * p + c], lb->pixels[3 * p + c]) << "pixel " << p;
    }
    EXPECT_GT(clear, alpha->pixels.size() / 2);
}
