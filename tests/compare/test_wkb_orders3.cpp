// WKB's traced orders 3 and up (render.wkb_orders3 "traced": src/vrl/Orders3Grid.cpp fills the
// radiance cache, src/wkb/RadianceGrid.cpp marches it; docs/wkb.md "Orders 3 and up, traced")
// against the path tracer's orders 3 and up: its L2plus unbounded minus its L2plus with max_depth
// 2, on a small homogeneous sphere seen against the light (g 0.7: the orders-3+ radiance is
// anisotropic there) and a heterogeneous procedural cloud seen from the side.
//
// Accepted: the image energy of orders 3+ within the L2plus energy target, 5% (issue 13,
// "Targets"), after checking that the path tracer's own standard error is well under it. Variants
// that must fail the same check: the cache projected toward the camera's mirror image (the phase
// function's direction reversed), and a cache missing order 3 (segments from the third scattering vertex on) or
// counting order 2 twice (from the first).
//
// Several lights: the cache keeps one layer per light whose AOV is written, and each light's layer
// is held against the path tracer's orders 3+ of that light (its light_<name> AOV unbounded minus
// at max_depth 2) with the same 5% target; the layers must sum to the one-layer cache (the same
// deposits), and a full render's per-light AOVs must add up to its beauty less L0.
#include "engine/Renderer.h"
#include "render/RenderContext.h"
#include "scene/KernelScene.h"
#include "single/ScatterPoints.h"
#include "single/SingleScatter.h"
#include "vrl/Orders3Grid.h"
#include "vrl/SkinCells.h"
#include "wkb/RadianceGrid.h"

#include "../../kernels/shared/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

using namespace nimbus;

namespace {

constexpr double kEnergyTarget = 0.05;

void useTempKernelCache()
{
    setenv("NIMBUS_CACHE_DIR", (std::string(::testing::TempDir()) + "nimbus-kernel-cache-orders3").c_str(), 1);
}

double channelMean(const Aov& a, size_t i)
{
    const float* p = a.pixels.data() + i * size_t(a.channels);
    return (p[0] + p[1] + p[2]) / 3.0;
}

Scene baseScene(float3 from, float3 lightTravel)
{
    Scene s;
    s.camera.width = 32;
    s.camera.height = 32;
    s.camera.from = from;
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 36;
    Light sun;
    sun.name = "sun";
    sun.type = LightType::Distant;
    sun.direction = normalize(lightTravel);
    sun.irradiance = splat(3.0f);
    s.lights.push_back(sun);
    s.render.pixelFilter = PixelFilter::Box;
    s.render.filterWidth = 1.0f;
    s.output.file = "unused.exr";
    return s;
}

// A procedural volume of one grey medium: extinction sigmaT (1/m at density 1), albedo, HG g.
Volume greyVolume(const char* name, const char* generator, std::map<std::string, double> params, float sigmaT,
                  float albedo, float g)
{
    Volume v;
    v.name = name;
    v.source.type = SourceType::Procedural;
    v.source.generator = generator;
    v.source.params = std::move(params);
    v.medium.sigma_s = splat(sigmaT * albedo);
    v.medium.sigma_a = splat(sigmaT * (1 - albedo));
    v.medium.phase = NbPhase{g, 0, 0, 0};
    return v;
}

Scene sphereAgainstTheLight()
{
    Scene s = baseScene(make_float3(0.0f, 0.3f, -4.0f), make_float3(0, -0.08f, -1));
    // optical diameter 4
    s.volumes.push_back(greyVolume("sphere", "sphere", {{"radius", 1.0}, {"voxel_size", 0.05}, {"falloff", 0.05}},
                                   2.0f, 0.95f, 0.7f));
    return s;
}

Scene cloudFromTheSide()
{
    Scene s = baseScene(make_float3(4.0f, 0.4f, 0.5f), make_float3(0.2f, -0.4f, -1));
    Volume v;
    v.name = "cloud";
    v.source.type = SourceType::Procedural;
    v.source.generator = "cloud";
    v.source.params = {{"radius", 1.0}, {"voxel_size", 1.0 / 24}};
    v.medium.sigma_s = make_float3(5.0f, 5.2f, 5.4f);
    v.medium.sigma_a = splat(0.05f);
    v.medium.phase = NbPhase{0.6f, -0.3f, 0.2f, 0};  // two lobes
    s.volumes.push_back(v);
    return s;
}

struct Reference {
    double energy = 0;       // image mean of orders 3+ (channel mean)
    double se = 0;           // its standard error
    double orders2Plus = 0;  // image mean of orders 2+ (the unbounded L2plus); its error under se
};

// The path tracer's orders 3+: L2plus unbounded minus L2plus at max_depth 2, independent seeds.
Reference pathTracedOrders3(Scene s, int spp)
{
    useTempKernelCache();
    s.render.method = Method::Pathtrace;
    s.render.spp = spp;
    double energy[2] = {0, 0}, var = 0;
    for (int k = 0; k < 2; ++k) {
        s.render.maxDepth = k == 0 ? 0 : 2;
        s.render.seed = 11 + uint32_t(k);
        const RenderResult r = render(s);
        const Aov* l2 = r.film.find("L2plus");
        const Aov* v = r.film.find("variance");
        EXPECT_TRUE(l2 && v);
        if (!l2 || !v)
            return {};
        const size_t n = size_t(r.film.width * r.film.height);
        for (size_t i = 0; i < n; ++i) {
            energy[k] += channelMean(*l2, i) / double(n);
            var += v->pixels[i] / double(n) / double(n);  // beauty's variance bounds L2plus's
        }
    }
    return {energy[0] - energy[1], std::sqrt(var), energy[0]};
}

// The camera's orders 3+ read from `grid` through 4 x 4 stratified rays a pixel: f(pixel, L, layers)
// per ray, pixel = y W + x, L the layers' sum and layers each layer's (grid.layers() entries).
template <class F>
void forEachOrders3Ray(const Scene& s, const RenderContext& ctx, const wkb::RadianceGrid& grid, F&& f)
{
    const NbCamera cam = makeNbCamera(s.camera);
    const int W = s.camera.width, H = s.camera.height, k = 4;
    std::vector<float3> layer(size_t(grid.layers()));
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            for (int j = 0; j < k * k; ++j) {
                float3 org, d;
                nbCameraRay(cam, x + (float(j % k) + 0.5f) / k, y + (float(j / k) + 0.5f) / k, W, H, 0.0f, &org, &d);
                const float3 L = wkb::marchOrders3(ctx.volumes, grid, org, d, INFINITY, 0.0f,
                                                   float((j * 7 + 3) % 16) / 16.0f, s.render.step, 2.0f, layer.data());
                f(size_t(y * W + x), L, layer.data());
            }
}

constexpr int kRaysPerPixel = 16;  // forEachOrders3Ray's

// Image means of each layer of `grid`; the layers' sum is the last entry.
std::vector<double> layerMeans(const Scene& s, const RenderContext& ctx, const wkb::RadianceGrid& grid)
{
    const size_t nl = size_t(grid.layers());
    std::vector<double> sum(nl + 1, 0.0);
    forEachOrders3Ray(s, ctx, grid, [&](size_t, float3 L, const float3* layer) {
        for (size_t l = 0; l < nl; ++l)
            sum[l] += (layer[l].x + layer[l].y + layer[l].z) / 3.0;
        sum[nl] += (L.x + L.y + L.z) / 3.0;
    });
    for (double& v : sum)
        v /= double(s.camera.width * s.camera.height * kRaysPerPixel);
    return sum;
}

// Each pixel's orders 3+ from `grid` (the channel mean over its rays), row by row.
std::vector<double> orders3Pixels(const Scene& s, const RenderContext& ctx, const wkb::RadianceGrid& grid)
{
    std::vector<double> px(size_t(s.camera.width * s.camera.height), 0.0);
    forEachOrders3Ray(s, ctx, grid, [&](size_t pixel, float3 L, const float3*) {
        px[pixel] += (L.x + L.y + L.z) / 3.0 / double(kRaysPerPixel);
    });
    return px;
}

// WKB's orders 3+ (the image mean over pixels, 4 x 4 stratified rays each) from a cache traced
// with `firstOrder`, projected toward the camera or, with `flip`, toward the camera's mirror image
// through the volumes' centre (each cell's direction to the viewer about reversed, as if read
// toward d instead of -d); skin: the cache's skin cells on.
double wkbOrders3(const Scene& s, const RenderContext& ctx, int firstOrder, bool flip, bool skin = true,
                  bool focus = true)
{
    vrl::Orders3Options o;
    o.skinCells = skin;
    o.focus = focus;
    o.maxPaths = vrl::orders3PathCap(s);  // paths 0: the adaptive count, as a render has it
    o.maxCells = vrl::orders3GridCells(ctx);
    o.seed = 5;
    o.firstOrder = firstOrder;
    if (flip) {
        o.hasViewer = true;
        o.viewer = 2.0f * ctx.volumes.worldBounds().center() - s.camera.from;
    }
    const auto grid = vrl::traceOrders3(ctx, o);
    EXPECT_TRUE(grid);
    if (!grid)
        return 0;
    EXPECT_EQ(grid->layers(), 1);
    double sum = 0;
    for (double v : orders3Pixels(s, ctx, *grid))
        sum += v;
    return sum / double(s.camera.width * s.camera.height);
}

// flipMatters: the view is along the light (against or with it), where p_1 decides the answer.
void checkScene(const char* name, const Scene& s, bool flipMatters, int spp)
{
    const Reference ref = pathTracedOrders3(s, spp);
    ASSERT_GT(ref.energy, 0.0) << name;
    ASSERT_LT(ref.se, 0.2 * kEnergyTarget * ref.energy) << name << ": the reference is too noisy to test 5%";
    const auto ctx = RenderContext::create(s, true);
    const double traced = wkbOrders3(s, *ctx, 2, false);
    const double flipped = wkbOrders3(s, *ctx, 2, true);
    const double missing3 = wkbOrders3(s, *ctx, 3, false);
    const double twice2 = wkbOrders3(s, *ctx, 1, false);
    auto rel = [&](double v) { return (v - ref.energy) / ref.energy; };
    std::printf("%s: orders 3+ path tracer %.5f +- %.5f; traced %+.3f, flipped %+.3f, missing order 3 %+.3f, "
                "order 2 twice %+.3f (relative)\n",
                name, ref.energy, ref.se, rel(traced), rel(flipped), rel(missing3), rel(twice2));
    // The cache from the first scattering vertex (render.wkb_order2 "cache") holds orders 2+: the
    // path tracer's whole L2plus.
    const double rel2 = (twice2 - ref.orders2Plus) / ref.orders2Plus;
    std::printf("%s: orders 2+ path tracer %.5f; the cache from the first vertex %+.3f, from the second %+.3f\n",
                name, ref.orders2Plus, rel2, (traced - ref.orders2Plus) / ref.orders2Plus);
    EXPECT_LT(std::fabs(rel2), kEnergyTarget) << name << ": orders 2+ from the cache";
    EXPECT_LT(std::fabs(rel(traced)), kEnergyTarget) << name;
    if (flipMatters) {
        EXPECT_GT(std::fabs(rel(flipped)), kEnergyTarget) << name << ": the cache read in the flipped direction passes";
    }
    EXPECT_GT(std::fabs(rel(missing3)), kEnergyTarget) << name << ": a cache missing order 3 passes";
    EXPECT_GT(std::fabs(rel(twice2)), kEnergyTarget) << name << ": a cache counting order 2 twice passes";
}

}  // namespace

TEST(WkbOrders3, SphereAgainstTheLightMatchesThePathTracer)
{
    const Scene s = sphereAgainstTheLight();
    checkScene("sphere against the light", s, true, 4096);
}

TEST(WkbOrders3, HeterogeneousCloudMatchesThePathTracer)
{
    const Scene s = cloudFromTheSide();
    checkScene("cloud from the side", s, true, 1024);
}

namespace {

// The sphere (albedo 0.95, g 0.3) under a sun from the camera's left and a second distant light
// from behind the camera, half the sun's irradiance: the two lights' parts differ in size and in
// where they are. (Both distant: a point light's paths mostly miss a small volume, and its layer
// would need many more paths than the default to test 5%.)
Scene twoLights()
{
    Scene s = baseScene(make_float3(0.0f, 0.3f, -4.0f), make_float3(1.0f, -0.3f, 0.2f));
    Light moon;
    moon.name = "moon";
    moon.type = LightType::Distant;
    moon.direction = normalize(make_float3(-0.4f, -0.5f, 1.0f));
    moon.irradiance = splat(1.5f);
    s.lights.push_back(moon);
    Volume v;
    v.name = "sphere";
    v.source.type = SourceType::Procedural;
    v.source.generator = "sphere";
    v.source.params = {{"radius", 1.0}, {"voxel_size", 0.05}, {"falloff", 0.05}};
    const float sigmaT = 2.0f, albedo = 0.95f;
    v.medium.sigma_s = splat(sigmaT * albedo);
    v.medium.sigma_a = splat(sigmaT * (1 - albedo));
    v.medium.phase = NbPhase{0.3f, 0, 0, 0};
    s.volumes.push_back(v);
    return s;
}

// A small cache over the two lights' scene: `paths` light paths, at most `maxCells` cells across,
// perLightAovs as the film asks.
// The adaptive count as a render of `s` has it (Orders3Options::paths 0), seed 5.
vrl::Orders3Options adaptiveCache(const Scene& s, const RenderContext& ctx)
{
    vrl::Orders3Options o;
    o.maxCells = vrl::orders3GridCells(ctx);
    o.maxPaths = vrl::orders3PathCap(s);
    o.seed = 5;
    return o;
}

vrl::Orders3Options smallCache(int paths, int maxCells, std::vector<char> perLightAovs)
{
    vrl::Orders3Options o;
    o.paths = paths;
    o.maxCells = maxCells;
    o.perLightAovs = std::move(perLightAovs);
    return o;
}

}  // namespace

TEST(WkbOrders3, PerLightLayersMatchEachLightsPathTracedOrders3)
{
    const Scene s = twoLights();
    // The path tracer's orders 3+ per light: light_<name> unbounded minus at max_depth 2.
    useTempKernelCache();
    Scene pt = s;
    pt.render.method = Method::Pathtrace;
    pt.render.spp = 4096;
    double ref[2][2] = {{0, 0}, {0, 0}}, var = 0;  // [depth run][light]
    for (int k = 0; k < 2; ++k) {
        pt.render.maxDepth = k == 0 ? 0 : 2;
        pt.render.seed = 21 + uint32_t(k);
        const RenderResult r = render(pt);
        const Aov* v = r.film.find("variance");
        ASSERT_TRUE(v);
        const size_t n = size_t(r.film.width * r.film.height);
        for (int l = 0; l < 2; ++l) {
            const Aov* a = r.film.find(l == 0 ? "light_sun" : "light_moon");
            ASSERT_TRUE(a);
            for (size_t i = 0; i < n; ++i)
                ref[k][l] += channelMean(*a, i) / double(n);
        }
        for (size_t i = 0; i < n; ++i)
            var += v->pixels[i] / double(n) / double(n);  // the beauty's variance bounds each light's
    }
    const double se = std::sqrt(var);
    const double refOrders3[2] = {ref[0][0] - ref[1][0], ref[0][1] - ref[1][1]};

    const auto ctx = RenderContext::create(s, true);
    vrl::Orders3Options o;
    o.maxPaths = vrl::orders3PathCap(s);  // paths 0: the adaptive count, as a render has it
    o.maxCells = vrl::orders3GridCells(*ctx);
    o.seed = 5;
    const auto summed = vrl::traceOrders3(*ctx, o);
    o.perLightAovs = {1, 1};
    const auto perLight = vrl::traceOrders3(*ctx, o);
    ASSERT_TRUE(summed && perLight);
    ASSERT_EQ(summed->layers(), 1);
    EXPECT_EQ(summed->layerLight(0), -1);
    ASSERT_EQ(perLight->layers(), 2);
    // The layers hold the same deposits as the one-layer cache, split by light.
    {
        const auto& a = summed->data();
        const auto& b = perLight->data();
        const size_t F = wkb::RadianceGrid::kFloats;
        ASSERT_EQ(b.size(), 2 * a.size());
        double worst = 0, scale = 0;
        for (size_t c = 0; c < summed->cellCount(); ++c)
            for (size_t k = 0; k < F; ++k) {
                const double one = a[c * F + k], two = double(b[c * 2 * F + k]) + double(b[c * 2 * F + F + k]);
                worst = std::max(worst, std::fabs(one - two));
                scale = std::max(scale, std::fabs(one));
            }
        EXPECT_LT(worst, 1e-4 * scale) << "the layers do not sum to the one-layer cache";
    }
    const std::vector<double> m = layerMeans(s, *ctx, *perLight);
    for (int layer = 0; layer < 2; ++layer) {
        const int li = perLight->layerLight(layer);
        ASSERT_TRUE(li == 0 || li == 1);
        const double r = refOrders3[li];
        ASSERT_GT(r, 0.0);
        ASSERT_LT(se, 0.2 * kEnergyTarget * r) << "the reference is too noisy to test 5% for light " << li;
        const double rel = (m[size_t(layer)] - r) / r;
        // A cache that gave one light the other's (or the sum) is far off: the lights differ by a third or more.
        const double swapped = (m[size_t(1 - layer)] - r) / r;
        std::printf("light %d: orders 3+ path tracer %.5f +- %.5f; its layer %+.3f, the other's %+.3f (relative)\n",
                    li, r, se, rel, swapped);
        EXPECT_LT(std::fabs(rel), kEnergyTarget) << "light " << li;
        EXPECT_GT(std::fabs(swapped), kEnergyTarget) << "light " << li << ": the other light's layer passes";
    }
}

// Where order 2 is traced, the camera ray's orders 3+ are read over traced order 2's own march of
// it (readOrders3 over a ScatterPointSampler's steps) instead of a march of their own
// (marchOrders3): the same integral, int T sigma_s S dt, on the same lattice of steps. Per layer
// (the two lights' scene), both reads' image means agree within 1% (stratified jitters, 16 rays a
// pixel), and so do the brightest pixels'. A read that left out the transmittance's decay within
// a step, or read S at a step's start instead of at its probe, is off by more on this sphere of
// optical diameter 4 (T falls by e^{-0.1} over a step of one voxel).
TEST(WkbOrders3, TracedOrder2sMarchReadsTheCacheAsItsOwnMarch)
{
    const Scene s = twoLights();
    const auto ctx = RenderContext::create(s, true);
    vrl::Orders3Options o = smallCache(65536, vrl::orders3GridCells(*ctx), {1, 1});
    o.seed = 5;
    const auto grid = vrl::traceOrders3(*ctx, o);
    ASSERT_TRUE(grid);
    ASSERT_EQ(grid->layers(), 2);
    const NbCamera cam = makeNbCamera(s.camera);
    const int W = s.camera.width, H = s.camera.height, k = 4;
    double marched[2] = {0, 0}, read[2] = {0, 0}, worst = 0, brightest = 0;
    float3 lm[2], lr[2];
    ScatterPointSampler sampler;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            double pm = 0, pr = 0;
            for (int j = 0; j < k * k; ++j) {
                float3 org, d;
                nbCameraRay(cam, x + (float(j % k) + 0.5f) / k, y + (float(j / k) + 0.5f) / k, W, H, 0.0f, &org, &d);
                NbRng rng = nbRngStart(9, uint32_t(y * W + x), uint32_t(j));
                wkb::marchOrders3(ctx->volumes, *grid, org, d, INFINITY, 0.0f, nbRngNext(&rng), s.render.step, 2.0f,
                                  lm);
                lr[0] = lr[1] = make_float3(0, 0, 0);
                if (sampler.march(*ctx, org, d, INFINITY, rng))
                    wkb::readOrders3(*grid, sampler, org, d, lr);
                for (int l = 0; l < 2; ++l) {
                    marched[l] += (lm[l].x + lm[l].y + lm[l].z) / 3.0;
                    read[l] += (lr[l].x + lr[l].y + lr[l].z) / 3.0;
                    pm += (lm[l].x + lm[l].y + lm[l].z) / 3.0;
                    pr += (lr[l].x + lr[l].y + lr[l].z) / 3.0;
                }
            }
            if (pm > brightest) {
                brightest = pm;
                worst = std::fabs(pr - pm) / pm;
            }
        }
    for (int l = 0; l < 2; ++l) {
        ASSERT_GT(marched[l], 0.0);
        const double rel = read[l] / marched[l] - 1.0;
        std::printf("layer %d: orders 3+ read over the sampler's steps %+.4f against its own march\n", l, rel);
        EXPECT_LT(std::fabs(rel), 0.01) << "layer " << l;
    }
    std::printf("brightest pixel: %+.4f\n", worst);
    EXPECT_LT(worst, 0.01);
}

TEST(WkbOrders3, PerLightAovsAddUpToTheBeautyAndOneLayerWhereNoneIsWritten)
{
    Scene s = twoLights();
    useTempKernelCache();
    s.render.method = Method::Wkb;
    s.render.wkbOrders3 = WkbOrders3::Traced;
    s.render.spp = 1;
    s.camera.width = s.camera.height = 24;
    const RenderResult r = render(s);
    const Aov* beauty = r.film.find("beauty");
    const Aov* L0 = r.film.find("L0");
    const Aov* L2 = r.film.find("L2plus");
    const Aov* sun = r.film.find("light_sun");
    const Aov* moon = r.film.find("light_moon");
    ASSERT_TRUE(beauty && L0 && L2 && sun && moon);
    // No emission: every radiance term past L0 is some light's, so the light AOVs add up to beauty - L0.
    const size_t n = size_t(r.film.width * r.film.height);
    double worst = 0, peak = 0, l2 = 0;
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            const double want = double(beauty->pixels[4 * i + size_t(c)]) - double(L0->pixels[3 * i + size_t(c)]);
            const double got = double(sun->pixels[3 * i + size_t(c)]) + double(moon->pixels[3 * i + size_t(c)]);
            worst = std::max(worst, std::fabs(want - got));
            peak = std::max(peak, std::fabs(want));
            l2 += L2->pixels[3 * i + size_t(c)];
        }
    ASSERT_GT(l2, 0.0);
    EXPECT_LT(worst, 1e-4 * peak) << "the per-light AOVs do not add up to beauty - L0";

    // Only the beauty written (the CLI's film): the cache keeps one summed layer.
    const auto ctx = RenderContext::create(s, true);
    vrl::Orders3Options o = smallCache(4096, 16, {0, 0});
    const auto none = vrl::traceOrders3(*ctx, o);
    ASSERT_TRUE(none);
    EXPECT_EQ(none->layers(), 1);
    // One light's AOV written: its layer and one for the other light.
    o.perLightAovs = {0, 1};
    const auto one = vrl::traceOrders3(*ctx, o);
    ASSERT_TRUE(one);
    ASSERT_EQ(one->layers(), 2);
    EXPECT_EQ(one->layerLight(0), 1);
    EXPECT_EQ(one->layerLight(1), -1);
}

// A lit face of a thick medium of low albedo (the skin cells' case, src/vrl/SkinCells.h): a box
// 2 x 1 x 2 m, sigma_t 192 per m (12 mean free paths per voxel, 8 per cache cell), albedo 0.8,
// isotropic (diffusion length 1.3 mean free paths), lit by a sun 30 degrees from the normal and seen
// from 40 degrees on the far side, the camera on the face only. The volume mean of a cell dilutes
// orders 3+, which live in the top mean free paths (the half-space table of docs/validation.md:
// 23-45% dark); the camera-weighted skin cells must match the path tracer within the target, and
// the same check must fail for the volume mean.
namespace {

// The lit faces below: a box 2 x 1 x 2 m, sigma_t 192 per m, albedo 0.8, HG g, lit on its top face
// by a sun 30 degrees from the normal (sunZ: the z of its travel direction, +-sin 30 degrees), seen
// through a 10 degree lens from 3 m at `view` radians from the normal (the camera at -z).
Scene litFace(float view, float sunZ, float g)
{
    Scene s = baseScene(make_float3(0.0f, 0.5f + 3.0f * std::cos(view), -3.0f * std::sin(view)),
                        make_float3(0.0f, -std::cos(0.5236f), sunZ));
    s.camera.to = make_float3(0, 0.5f, 0);
    s.camera.fov = 10;
    s.volumes.push_back(greyVolume("slab", "box",
                                   {{"size_x", 2.0}, {"size_y", 1.0}, {"size_z", 2.0}, {"voxel_size", 0.0625}},
                                   192.0f, 0.8f, g));
    return s;
}

}  // namespace

TEST(WkbOrders3, LitFaceMatchesThePathTracerWithSkinCells)
{
    const Scene s = litFace(0.698f, std::sin(0.5236f), 0.0f);
    const Reference ref = pathTracedOrders3(s, 1024);
    ASSERT_GT(ref.energy, 0.0);
    ASSERT_LT(ref.se, 0.2 * kEnergyTarget * ref.energy) << "the reference is too noisy to test 5%";
    const auto ctx = RenderContext::create(s, true);
    const double skin = wkbOrders3(s, *ctx, 2, false, true);
    const double mean = wkbOrders3(s, *ctx, 2, false, false);
    auto rel = [&](double x) { return (x - ref.energy) / ref.energy; };
    std::printf("lit face: orders 3+ path tracer %.5f +- %.5f; skin cells %+.3f, volume mean %+.3f (relative)\n",
                ref.energy, ref.se, rel(skin), rel(mean));
    EXPECT_LT(std::fabs(rel(skin)), kEnergyTarget);
    EXPECT_GT(std::fabs(rel(mean)), kEnergyTarget) << "the volume mean passes: the test cannot tell";
}

// The g 0.7 rows of the half-space table (docs/validation.md "Paths aimed at the view"): a lit face
// of albedo 0.8 and g 0.7 seen 60 degrees off its normal on the far side from the sun, through a
// lens that sees a small part of it. Orders 3+ within 5% of the path tracer's with the light
// paths aimed at the view (ViewFocus.h); without the aim the default paths leave the cells the
// camera reads undersampled (printed, not asserted: the shortfall is noise, -4.9% on this seed;
// -31% on the half-space table's larger face).
TEST(WkbOrders3, ObliqueForwardLitFaceMatchesThePathTracerWithAimedPaths)
{
    const Scene s = litFace(1.047f, -std::sin(0.5236f), 0.7f);  // 60 degrees, the sun's azimuth opposite
    const Reference ref = pathTracedOrders3(s, 1024);
    ASSERT_GT(ref.energy, 0.0);
    ASSERT_LT(ref.se, 0.2 * kEnergyTarget * ref.energy) << "the reference is too noisy to test 5%";
    const auto ctx = RenderContext::create(s, true);
    const double aimed = wkbOrders3(s, *ctx, 2, false, true, true);
    const double spread = wkbOrders3(s, *ctx, 2, false, true, false);
    auto rel = [&](double x) { return (x - ref.energy) / ref.energy; };
    std::printf("oblique lit face, g 0.7: orders 3+ path tracer %.5f +- %.5f; aimed paths %+.3f, not aimed %+.3f "
                "(relative)\n",
                ref.energy, ref.se, rel(aimed), rel(spread));
    EXPECT_LT(std::fabs(rel(aimed)), kEnergyTarget);
}

// Deposits aimed at the camera (Orders3Grid.cpp, aimDeposit) keep the cache's mean and lower its
// noise where the phase function is narrow: the side-lit cloud at HG g 0.9, four seeds each way at
// a fixed path count. The means of orders 3+ (image mean, 4 x 4 rays a pixel) agree within 4
// standard errors of their difference (from the seeds' spread); the noise, each pixel's variance
// over the seeds relative to the squared image mean, at most half the light paths' own (the
// weight p(w . wo) the paths' directions carry spans 190x its mean at g 0.9, the aimed one at most 2).
TEST(WkbOrders3, AimedDepositsKeepTheMeanAndLowerTheNoise)
{
    Scene s = cloudFromTheSide();
    s.volumes[0].medium.phase = NbPhase{0.9f, 0, 0, 0};
    const auto ctx = RenderContext::create(s, true);
    constexpr int kSeeds = 4;
    const int W = s.camera.width, H = s.camera.height;
    auto image = [&](bool aim, uint32_t seed) {
        vrl::Orders3Options o = smallCache(65536, vrl::orders3GridCells(*ctx), {});
        o.seed = seed;
        o.aimDeposits = aim;
        const auto grid = vrl::traceOrders3(*ctx, o);
        EXPECT_TRUE(grid);
        return grid ? orders3Pixels(s, *ctx, *grid) : std::vector<double>(size_t(W * H), 0.0);
    };
    struct Stats {
        double mean = 0, se = 0, noise = 0;
    };
    auto stats = [&](bool aim) {
        std::vector<std::vector<double>> im;
        for (int i = 0; i < kSeeds; ++i)
            im.push_back(image(aim, 21 + uint32_t(i)));
        Stats st;
        std::vector<double> means(kSeeds, 0.0);
        for (int i = 0; i < kSeeds; ++i) {
            for (double v : im[size_t(i)])
                means[size_t(i)] += v / double(W * H);
            st.mean += means[size_t(i)] / kSeeds;
        }
        for (double m : means)
            st.se += (m - st.mean) * (m - st.mean) / double(kSeeds - 1) / double(kSeeds);
        st.se = std::sqrt(st.se);
        for (size_t p = 0; p < size_t(W * H); ++p) {
            double m = 0, v = 0;
            for (int i = 0; i < kSeeds; ++i)
                m += im[size_t(i)][p] / kSeeds;
            for (int i = 0; i < kSeeds; ++i)
                v += (im[size_t(i)][p] - m) * (im[size_t(i)][p] - m) / double(kSeeds - 1);
            st.noise += v / double(W * H);
        }
        st.noise /= st.mean * st.mean;
        return st;
    };
    const Stats aimed = stats(true), own = stats(false);
    std::printf("cloud at g 0.9, orders 3+: aimed %.5f +- %.5f (noise %.3g), the paths' own directions %.5f +- "
                "%.5f (noise %.3g)\n",
                aimed.mean, aimed.se, aimed.noise, own.mean, own.se, own.noise);
    EXPECT_LT(std::fabs(aimed.mean - own.mean), 4.0 * std::sqrt(aimed.se * aimed.se + own.se * own.se));
    EXPECT_LT(aimed.noise, 0.5 * own.noise);
}

// The memory estimate's model of the cache while it is filled (vrl::orders3FillBytes, the
// "orders-3+ radiance cache" item of `nimbus info`) against the grids traceOrders3 allocates: the
// cache (its own data) and max(2, 8 / layers) partial grids of the same size, and the skin pass's
// per-cell accumulators (docs/wkb.md
// "Per-light AOVs"); with two lights the worst layer count is 2 (2 + 4 x 2 one-layer grids, over
// 1 + 8 for one layer). The adaptive count (paths 0) holds two grids more while it measures the
// noise: the second half's cache and the blur's buffer.
TEST(WkbOrders3, FillMemoryModelIsTheGridsItAllocates)
{
    Scene s = twoLights();
    useTempKernelCache();
    const auto ctx = RenderContext::create(s, true);
    const vrl::Orders3Options o = smallCache(4096, 20, {1, 1});
    vrl::Orders3Report report;
    const auto grid = vrl::traceOrders3(*ctx, o, &report);
    ASSERT_TRUE(grid);
    EXPECT_EQ(report.paths, 4096);  // a fixed count: the paths asked for, blurred
    EXPECT_FALSE(report.adaptive);
    EXPECT_TRUE(report.blurred);
    ASSERT_EQ(grid->layers(), 2);
    EXPECT_EQ(wkb::RadianceGrid::cellCountFor(ctx->volumes.worldBounds(), 0.0f, o.maxCells), grid->cellCount());
    const size_t gridBytes = grid->data().size() * sizeof(float);
    EXPECT_EQ(vrl::orders3FillBytes(*ctx, o), gridBytes * (1 + 4) + vrl::skinCellsBytes(grid->cellCount()));
    vrl::Orders3Options adaptive = o;
    adaptive.paths = 0;
    EXPECT_EQ(vrl::orders3FillBytes(*ctx, adaptive), gridBytes * (3 + 4) + vrl::skinCellsBytes(grid->cellCount()));
}

// The adaptive count (Orders3Options::paths 0) measures the relMSE the cache's noise adds to the
// image from two halves of one cache. Held against the same quantity measured without it: two
// caches of independent seeds at the count it chose, read by the camera's pixel centres, whose
// difference has twice one cache's variance. The two estimates are sample means of a skewed
// quantity (a cell lit by one rare bright path moves both), held within 4 of their combined
// standard errors (each from its terms' spread over 2 x 2 pixel blocks: 0.0003 and 0.0002 of
// 0.0022 and 0.0026 here); an estimator off by the half's scale (4x) or reading the sum's spread as
// a half's (2x the other way, squared) fails. The count is deterministic for a seed. The cloud's
// sharp cache asks for more paths than its blurred one, so it is blurred, as the fixed counts'
// caches are.
TEST(WkbOrders3, AdaptivePathCountMeasuresTheCachesNoise)
{
    Scene s = cloudFromTheSide();
    // 64 x 64: the pilots stay at 32 x 32 (every other pixel), the two seeds are read at all 4096
    // pixels, which halves their estimate's standard error.
    s.camera.width = s.camera.height = 64;
    useTempKernelCache();
    const auto ctx = RenderContext::create(s, true);
    const vrl::Orders3Options o = adaptiveCache(s, *ctx);
    vrl::Orders3Report report, again;
    const auto grid = vrl::traceOrders3(*ctx, o, &report);
    const auto grid2 = vrl::traceOrders3(*ctx, o, &again);
    ASSERT_TRUE(grid && grid2);
    ASSERT_TRUE(report.adaptive);
    ASSERT_TRUE(report.blurred);
    ASSERT_GT(report.noisePaths, 0);
    EXPECT_EQ(report.paths, again.paths);
    EXPECT_EQ(grid->data(), grid2->data());
    // The noise it measured, at the count it chose (noise falls as one over the paths).
    const double predicted = report.noiseMeasured * double(report.noisePaths) / double(report.paths);

    vrl::Orders3Options fixed = o;
    fixed.paths = report.paths;
    fixed.seed = 7;
    const auto a = vrl::traceOrders3(*ctx, fixed);
    fixed.seed = 8;
    const auto b = vrl::traceOrders3(*ctx, fixed);
    ASSERT_TRUE(a && b);
    const NbCamera cam = makeNbCamera(s.camera);
    const int W = s.camera.width, H = s.camera.height;
    std::vector<double> e2, v;
    std::vector<float> perLight(3 * ctx->lights.size());
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            float3 org, d;
            nbCameraRay(cam, x + 0.5f, y + 0.5f, W, H, 0.5f, &org, &d);
            const float3 A = wkb::marchOrders3(ctx->volumes, *a, org, d, INFINITY, 0.0f, 0.5f,
                                               s.render.step, 2.0f);
            const float3 B = wkb::marchOrders3(ctx->volumes, *b, org, d, INFINITY, 0.0f, 0.5f,
                                               s.render.step, 2.0f);
            CameraSample single;
            NbRng rng = nbRngStart(3, uint32_t(y * W + x), 0);
            std::fill(perLight.begin(), perLight.end(), 0.0f);
            marchSingle(*ctx, org, d, rng, single, perLight.data());
            const float a3[3] = {A.x, A.y, A.z}, b3[3] = {B.x, B.y, B.z};
            const float s3[3] = {single.L0.x + single.L1.x, single.L0.y + single.L1.y, single.L0.z + single.L1.z};
            for (int c = 0; c < 3; ++c) {
                const double diff = double(a3[c]) - double(b3[c]);
                e2.push_back(0.5 * diff * diff);  // one cache's variance
                v.push_back(double(s3[c]) + 0.5 * (double(a3[c]) + double(b3[c])));
            }
        }
    double mean = 0;
    for (double x : v)
        mean += x / double(v.size());
    const double eps = (0.1 * mean) * (0.1 * mean);
    // Per pixel, the mean of its channels' terms; the relMSE is their mean over the pixels.
    std::vector<double> term(size_t(W * H), 0.0);
    double measured = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        term[i / 3] += e2[i] / (v[i] * v[i] + eps) / 3.0;
        measured += e2[i] / (v[i] * v[i] + eps) / double(v.size());
    }
    // Standard errors of that mean: from the pixels' spread, and from the spread of 2 x 2 pixel
    // blocks (a cache cell spans about a pixel here and the blur three cells, so neighbours move
    // together: the block's is the honest one).
    auto stdErr = [&](int block) {
        std::vector<double> b;
        for (int y = 0; y + block <= H; y += block)
            for (int x = 0; x + block <= W; x += block) {
                double m = 0;
                for (int j = 0; j < block * block; ++j)
                    m += term[size_t((y + j / block) * W + x + j % block)] / double(block * block);
                b.push_back(m);
            }
        double bm = 0, ss = 0;
        for (double q : b)
            bm += q / double(b.size());
        for (double q : b)
            ss += (q - bm) * (q - bm);
        return std::sqrt(ss / double(b.size() - 1) / double(b.size()));
    };
    const double sePixel = stdErr(1), seMeasured = stdErr(2);
    // The pilots are centres of these pixels' 2 x 2 blocks, so their terms correlate about alike:
    // their per-ray standard error, scaled as the pixels' is by the blocks.
    const double sePredicted =
        report.noiseStdErr * (seMeasured / sePixel) * double(report.noisePaths) / double(report.paths);
    const double tolerance = 4.0 * std::sqrt(sePredicted * sePredicted + seMeasured * seMeasured);
    std::printf("adaptive count %lld paths: noise measured %.3g +- %.2g at %lld, %.3g predicted at the count; two "
                "seeds %.3g +- %.2g (per pixel +- %.2g)\n",
                report.paths, report.noiseMeasured, report.noiseStdErr, report.noisePaths, predicted, measured,
                seMeasured, sePixel);
    EXPECT_GT(measured, 0.0);
    EXPECT_GT(report.noiseStdErr, 0.0);
    EXPECT_LT(std::fabs(predicted - measured), tolerance) << "4 standard errors of the two estimates";
}

// The blur is left out where the sharp cache meets the noise target at the first round's 65536
// paths (an optically thin sphere: few paths scatter twice, and those spread evenly), and kept
// where it does not (the cloud above). Sharp, the cache is the sum of the partials alone.
TEST(WkbOrders3, AdaptiveCountLeavesAQuietCacheSharp)
{
    Scene s = baseScene(make_float3(0.0f, 0.3f, -4.0f), make_float3(0, -0.08f, -1));
    s.volumes.push_back(greyVolume("thin", "sphere", {{"radius", 1.0}, {"voxel_size", 0.05}, {"falloff", 0.05}},
                                   0.25f, 0.9f, 0.3f));  // optical diameter 0.5
    useTempKernelCache();
    const auto ctx = RenderContext::create(s, true);
    const vrl::Orders3Options o = adaptiveCache(s, *ctx);
    vrl::Orders3Report report;
    const auto grid = vrl::traceOrders3(*ctx, o, &report);
    ASSERT_TRUE(grid);
    std::printf("thin sphere: %lld paths, noise %.3g at %lld, %s\n", report.paths, report.noiseMeasured,
                report.noisePaths, report.blurred ? "blurred" : "sharp");
    EXPECT_FALSE(report.blurred);
    EXPECT_EQ(report.paths, 65536);
    EXPECT_LE(report.noiseMeasured, 0.002);
    // The same paths at the fixed count are blurred: the two caches differ.
    vrl::Orders3Options fixed = o;
    fixed.paths = report.paths;
    const auto blurred = vrl::traceOrders3(*ctx, fixed);
    ASSERT_TRUE(blurred);
    EXPECT_NE(grid->data(), blurred->data());
}

// The cache's cells along the box's longest side (render.wkb_orders3_grid 0, the default;
// orders3GridCells): 48, more where the densest medium makes a 48th of the box more than 0.375
// transport mean free paths 1 / (sigma_t (1 - g omega)) across while it is no skin cell (under 2
// transport lengths and 1 diffusion length), at most 96; a key's value as given. The procedural
// sphere of radius 1 at voxel 0.05 spans 2.4 m (a 48th: 0.05 m).
TEST(WkbOrders3, CacheCellsFollowTheDensestMediumsTransportLength)
{
    auto cells = [](float sigmaT, float albedo, float g, int key = 0) {
        Scene s = baseScene(make_float3(0.0f, 0.3f, -4.0f), make_float3(0, -0.08f, -1));
        s.volumes.push_back(greyVolume("sphere", "sphere", {{"radius", 1.0}, {"voxel_size", 0.05}, {"falloff", 0.05}},
                                       sigmaT, albedo, g));
        s.render.wkbOrders3Grid = key;
        const auto ctx = RenderContext::create(s, true);
        const Bbox box = ctx->volumes.worldBounds();
        EXPECT_NEAR(box.hi.x - box.lo.x, 2.4f, 1e-4f);
        return vrl::orders3GridCells(*ctx);
    };
    EXPECT_EQ(cells(2.0f, 0.95f, 0.7f), 48);    // a 48th is 0.034 transport lengths
    EXPECT_EQ(cells(20.0f, 0.995f, 0.3f), 90);  // 0.70 transport lengths: ceil(48 x 0.7015 / 0.375)
    EXPECT_EQ(cells(30.0f, 0.9995f, 0.5f), 96); // 0.75: 96 would be exceeded (ceil 97), so the most
    EXPECT_EQ(cells(300.0f, 0.95f, 0.3f), 48);  // 10.7 transport lengths: skin cells, not finer ones
    EXPECT_EQ(cells(20.0f, 0.5f, 0.0f), 48);    // 1 transport length, but 1.22 diffusion lengths: skin
    EXPECT_EQ(cells(30.0f, 0.9995f, 0.5f, 40), 40);
}
