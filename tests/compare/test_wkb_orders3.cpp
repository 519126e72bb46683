// WKB's traced orders 3 and up (render.wkb_orders3 "traced": src/vrl/Orders3Grid.cpp fills the
// radiance cache, src/wkb/RadianceGrid.cpp marches it; docs/wkb.md "Orders 3 and up, traced")
// against the path tracer's orders 3 and up: its L2plus unbounded minus its L2plus with max_depth
// 2, on a small homogeneous sphere seen against the light (g 0.7: the orders-3+ radiance is
// anisotropic there) and a heterogeneous procedural cloud seen from the side.
//
// Accepted: the image energy of orders 3+ within the L2plus energy target, 5% (issue 13,
// "Targets"), after checking that the path tracer's own standard error is well under it. Variants
// that must fail the same check: the cache read in the flipped direction (d instead of -d: the
// Funk-Hecke sign), and a cache missing order 3 (segments from the third scattering vertex on) or
// counting order 2 twice (from the first).
#include "engine/Renderer.h"
#include "render/RenderContext.h"
#include "scene/KernelScene.h"
#include "vrl/Orders3Grid.h"
#include "wkb/RadianceGrid.h"

#include "../../kernels/shared/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
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

Scene sphereAgainstTheLight()
{
    Scene s = baseScene(make_float3(0.0f, 0.3f, -4.0f), make_float3(0, -0.08f, -1));
    Volume v;
    v.name = "sphere";
    v.source.type = SourceType::Procedural;
    v.source.generator = "sphere";
    v.source.params = {{"radius", 1.0}, {"voxel_size", 0.05}, {"falloff", 0.05}};
    const float sigmaT = 2.0f, albedo = 0.95f;  // optical diameter 4
    v.medium.sigma_s = splat(sigmaT * albedo);
    v.medium.sigma_a = splat(sigmaT * (1 - albedo));
    v.medium.phase = NbPhase{0.7f, 0, 0, 0};
    s.volumes.push_back(v);
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
    double energy = 0;  // image mean of orders 3+ (channel mean)
    double se = 0;      // its standard error
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
    return {energy[0] - energy[1], std::sqrt(var)};
}

// WKB's orders 3+ (the image mean over pixels, 4 x 4 stratified rays each) from a cache traced
// with `firstOrder`, read toward `flip ? d : -d`.
double wkbOrders3(const Scene& s, const RenderContext& ctx, int firstOrder, bool flip)
{
    vrl::Orders3Options o;
    o.paths = s.render.wkbOrders3Paths;
    o.maxCells = s.render.wkbOrders3Grid;
    o.seed = 5;
    o.firstOrder = firstOrder;
    const auto grid = vrl::traceOrders3(ctx, o);
    EXPECT_TRUE(grid);
    if (!grid)
        return 0;
    std::vector<NbPhase> phases;
    for (const auto& v : ctx.volumes.volumes())
        phases.push_back(v->medium.phase);
    const NbCamera cam = makeNbCamera(s.camera);
    const int W = s.camera.width, H = s.camera.height, k = 4;
    double sum = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            for (int j = 0; j < k * k; ++j) {
                float3 org, d;
                nbCameraRay(cam, x + (float(j % k) + 0.5f) / k, y + (float(j / k) + 0.5f) / k, W, H, 0.0f, &org, &d);
                const float3 L = wkb::marchOrders3(ctx.volumes, phases, *grid, org, d, flip ? d : -d, INFINITY, 0.0f,
                                                   float((j * 7 + 3) % 16) / 16.0f, s.render.step, 2.0f);
                sum += (L.x + L.y + L.z) / 3.0;
            }
    return sum / double(W * H * k * k);
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
