// Method "wkb" end to end (issue 3 "How it is checked"): AOV contracts, the scattering-angle
// convention, stability over the listed extreme inputs (finite, non-negative, under a bound
// derived below), and energy: a thick conservative sphere gives back no more than it receives.
#include "../render/HandMadeVolume.h"

#include "engine/Renderer.h"
#include "render/RenderContext.h"
#include "scene/KernelScene.h"
#include "wkb/AngularKernel.h"
#include "wkb/WkbIntegrator.h"
#include "wkb/WkbPlanner.h"

#include <boost/math/quadrature/gauss.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

using namespace nimbus;
using namespace nimbus::test;

namespace {

Volume proceduralVolume(const std::string& generator, std::map<std::string, double> params, Rgb sigma_s, Rgb sigma_a,
                        float g)
{
    Volume v;
    v.name = generator;
    v.source.type = SourceType::Procedural;
    v.source.generator = generator;
    v.source.params = std::move(params);
    v.medium.sigma_s = sigma_s;
    v.medium.sigma_a = sigma_a;
    v.medium.phase = NbPhase{g, 0, 0, 0};
    return v;
}

Light sun(float3 direction, float E)
{
    Light l;
    l.name = "sun";
    l.type = LightType::Distant;
    l.direction = normalize(direction);
    l.irradiance = splat(E);
    return l;
}

Scene baseScene(int w, int h, float3 from, float3 to, float fov)
{
    Scene s;
    s.camera.width = w;
    s.camera.height = h;
    s.camera.from = from;
    s.camera.to = to;
    s.camera.fov = fov;
    s.render.method = Method::Wkb;
    s.render.spp = 1;
    s.render.shadowMapResolution = 64;
    s.output.file = "unused.exr";
    return s;
}

const Aov& aov(const Film& f, const char* name)
{
    const Aov* a = f.find(name);
    EXPECT_NE(a, nullptr) << name;
    return *a;
}

double mean(const Aov& a)
{
    double s = 0;
    for (float v : a.pixels)
        s += v;
    return s / double(a.pixels.size());
}

// 1/(4pi) sum_j (2j+1) |g|^j R_j(0): every angular factor S of a march node is at most this
// (R_j decreases with l; the node sum has at most the cap's orders).
double angularBound(wkb::KernelType k, float g, int orders)
{
    const double mu = wkb::gaussianMu(g);
    double sum = 0, gp = 1;
    for (int j = 0; j <= orders; ++j, gp *= std::fabs(g)) {
        double R = k == wkb::KernelType::Gaussian ? wkb::gaussianA(j, mu, 1e-9) : gp;
        sum += (2 * j + 1) * gp * R;
    }
    return sum / (4 * M_PI);
}

// The bound each stability case asserts, pixel by pixel: a node adds W S Eblur with
// sum W <= min(l_ray, omega^2 / (1 - omega)) (the weight integral over the ray, bounded by the
// ray's scattering depth and by its value over an infinite medium), S <= angularBound and
// Eblur <= the largest irradiance any source delivers (a density-weighted average of E).
double l2plusBound(double lRayMax, double omega, double angular, double Emax)
{
    double w = lRayMax;
    if (omega < 1.0)
        w = std::min(w, omega * omega / (1.0 - omega));
    return w * angular * Emax;
}

void expectFiniteNonNegativeBounded(const Film& film, double bound, const std::string& what)
{
    for (const Aov& a : film.aovs)
        for (size_t i = 0; i < a.pixels.size(); ++i) {
            ASSERT_TRUE(std::isfinite(a.pixels[i])) << what << ": " << a.name << " pixel value " << i;
            ASSERT_GE(a.pixels[i], 0.0f) << what << ": " << a.name << " pixel value " << i;
        }
    const Aov& l2 = aov(film, "L2plus");
    for (size_t i = 0; i < l2.pixels.size(); ++i)
        ASSERT_LE(l2.pixels[i], bound * (1 + 1e-4) + 1e-30) << what << ": L2plus pixel value " << i;
}

// A RenderContext built by hand around hand-made volumes (no loader), as RenderContext::create
// would for delta lights, with the plan's wkb part made by planWkb as the engine's planning pass
// makes it. The WkbIntegrator built on it has no traced radiance cache: the scene must say
// `wkb_orders3` kernel, what these tests check.
struct HandContext {
    std::unique_ptr<RenderContext> ctx;
    RenderPlan plan;
    RenderStats stats;
    RenderContext& operator*() { return *ctx; }
    RenderContext* operator->() { return ctx.get(); }
};

HandContext handContext(const Scene& scene, std::vector<std::shared_ptr<VolumeData>> vols)
{
    EXPECT_EQ(scene.render.wkbOrders3, WkbOrders3::Kernel) << "handContext builds the kernel's orders 3+";
    HandContext hc;
    hc.ctx = std::make_unique<RenderContext>();
    RenderContext* ctx = hc.ctx.get();
    ctx->scene = &scene;
    ctx->volumes = VolumeSet(std::move(vols), scene.render.step);
    ctx->background = scene.background;
    for (auto& v : ctx->volumes.volumes()) {
        VolumePlan vp;
        vp.name = v->name;
        hc.plan.volumes.push_back(vp);
    }
    // What marchSingle reads (wkb's traced order 2 marches it from inside the medium): the stiff
    // bricks and each shadow map baked on the voxels, as RenderContext::create and
    // buildShadowMaps make them.
    for (const auto& v : ctx->volumes.volumes())
        ctx->stiff.push_back(StiffVoxels::find(*v, scene.render.step * v->voxelSize));
    DeepShadowMap::Settings s;
    s.resolution = scene.render.shadowMapResolution;
    s.keepMarchSamples = true;
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        LightEntry e;
        e.light = makeNbLight(scene.lights[i], int(i));
        e.aov = "light_" + scene.lights[i].name;
        e.delta = nbLightIsDelta(e.light);
        e.used = !ctx->volumes.empty();
        if (e.delta && e.used) {
            e.shadowMap = DeepShadowMap::build(e.light, ctx->volumes, s);
            e.cache = LightCache::bake(*e.shadowMap, ctx->volumes);
            e.shadowMap->releaseMarchSamples();
        }
        ctx->lights.push_back(std::move(e));
        LightPlan lp;
        lp.name = scene.lights[i].name;
        hc.plan.lights.push_back(lp);
    }
    hc.plan.integrator = std::make_shared<const wkb::WkbSetup>(wkb::planWkb(*ctx, hc.plan));
    return hc;
}

// L2+ of every pixel centre of the scene's camera through a hand-built context.
std::vector<Rgb> marchL2plus(const RenderContext& ctx, const wkb::WkbIntegrator& w)
{
    const Scene& s = *ctx.scene;
    NbCamera cam = makeNbCamera(s.camera);
    std::vector<Rgb> out;
    std::vector<float> perLight(3 * ctx.lights.size());
    for (int y = 0; y < s.camera.height; ++y)
        for (int x = 0; x < s.camera.width; ++x) {
            float3 o, d;
            nbCameraRay(cam, x + 0.5f, y + 0.5f, s.camera.width, s.camera.height, 0.0f, &o, &d);
            NbRng rng = nbRngStart(1u, nb_uint(y * s.camera.width + x), 0u);
            CameraSample cs;
            w.march(o, d, rng, cs, perLight.data());
            out.push_back(cs.L2plus);
        }
    return out;
}

}  // namespace

// wkb's L0 and L1 are single's, bit for bit; beauty = L0 + L1 + L2plus; the light AOVs add up to
// L1 + L2plus (no emission here); L2+ is present.
TEST(WkbRender, AovsAddUpAndL0L1AreSingles)
{
    Scene s = baseScene(32, 24, make_float3(0, 0.3f, 6), make_float3(0, 0, 0), 30);
    s.volumes.push_back(
        proceduralVolume("cloud", {{"radius", 1.0}, {"voxel_size", 1.0 / 20}}, splat(6.0f), splat(0.06f), 0.7f));
    s.lights.push_back(sun(make_float3(0.4f, -1, -0.3f), 2.0f));
    Light point;
    point.name = "lamp";
    point.type = LightType::Point;
    point.position = make_float3(-2, 1, 2);
    point.intensity = make_float3(3, 2, 1);
    s.lights.push_back(point);
    s.render.spp = 2;
    RenderResult w = render(s);
    s.render.method = Method::Single;
    RenderResult single = render(s);

    EXPECT_EQ(aov(w.film, "L0").pixels, aov(single.film, "L0").pixels);
    EXPECT_EQ(aov(w.film, "L1").pixels, aov(single.film, "L1").pixels);
    const Aov &b = aov(w.film, "beauty"), &l0 = aov(w.film, "L0"), &l1 = aov(w.film, "L1"), &l2 = aov(w.film, "L2plus");
    const Aov &ls = aov(w.film, "light_sun"), &lp = aov(w.film, "light_lamp");
    for (size_t p = 0; p < l0.pixels.size() / 3; ++p)
        for (int c = 0; c < 3; ++c) {
            float sum = l0.pixels[3 * p + c] + l1.pixels[3 * p + c] + l2.pixels[3 * p + c];
            EXPECT_NEAR(b.pixels[4 * p + c], sum, 1e-6f + 1e-6f * sum) << p;
            float lights = ls.pixels[3 * p + c] + lp.pixels[3 * p + c];
            float terms = l1.pixels[3 * p + c] + l2.pixels[3 * p + c];
            EXPECT_NEAR(lights, terms, 1e-6f + 1e-5f * terms) << p;
        }
    EXPECT_GT(mean(l2), 0.05 * mean(l1));
    EXPECT_TRUE(w.plan.wkb.l2plus);
    EXPECT_NE(w.plan.describe().find("L2+"), std::string::npos);
}

// Phase convention: with g = 0.9 the multiply scattered light of a sunlit ball is brighter seen
// against the sun (light keeps going forward, toward the camera) than seen from the sun's side.
TEST(WkbRender, ForwardScatteringIsTowardTheCamera)
{
    double L2[2];
    for (int side = 0; side < 2; ++side) {
        float z = side == 0 ? -8.0f : 8.0f;  // 0: camera opposite the sun, looking toward it
        Scene s = baseScene(16, 16, make_float3(0.01f, 0, z), make_float3(0, 0, 0), 12);
        s.volumes.push_back(
            proceduralVolume("sphere", {{"radius", 0.8}, {"voxel_size", 0.05}}, splat(2.0f), splat(0.0f), 0.9f));
        s.lights.push_back(sun(make_float3(0, 0, -1), 1.0f));  // travels toward -z
        L2[side] = mean(aov(render(s).film, "L2plus"));
    }
    EXPECT_GT(L2[0], 2.0 * L2[1]) << "forward " << L2[0] << " backward " << L2[1];
}

// Stability (issue 3): each case renders finite, non-negative AOVs with L2+ under l2plusBound.
struct StabilityCase {
    const char* name;
    std::string generator;
    double size;   // radius (sphere) or edge (box), metres
    double voxel;  // metres
    float sigma_s, sigma_a, g;
    float3 camera;  // camera position; it looks at the origin
    bool pointLightInside = false;
    wkb::KernelType kernel = wkb::KernelType::Gaussian;
};

class WkbStability : public ::testing::TestWithParam<StabilityCase> {};

TEST_P(WkbStability, FiniteNonNegativeBounded)
{
    const StabilityCase& c = GetParam();
    const float R = float(c.size);
    Scene s = baseScene(12, 12, c.camera, make_float3(0, 0, 0), 40);
    std::map<std::string, double> params = {{c.generator == "box" ? "size" : "radius", c.size},
                                            {"voxel_size", c.voxel}};
    s.volumes.push_back(proceduralVolume(c.generator, params, splat(c.sigma_s), splat(c.sigma_a), c.g));
    double Emax = 1.0;
    if (c.pointLightInside) {
        Light l;
        l.name = "inside";
        l.type = LightType::Point;
        l.position = make_float3(0.1f * R, 0.05f * R, 0.0f);
        l.intensity = splat(1.0f);
        s.lights.push_back(l);
    } else {
        s.lights.push_back(sun(make_float3(0.3f, -1, 0.2f), 1.0f));
    }
    s.render.wkbKernel = c.kernel == wkb::KernelType::Gaussian ? WkbKernel::Gaussian : WkbKernel::Exact;
    // The bound is derived for the kernel's L2+ (weights times angular factors times irradiance):
    // orders 3+ by the kernel, not the traced cache (the default).
    s.render.wkbOrders3 = WkbOrders3::Kernel;
    RenderResult r = render(s);
    if (c.pointLightInside) {  // E <= I / r_min^2, r_min = half a light voxel (LightVolumes::deltaE)
        double rMin = 0.5 * c.voxel * std::max(1, r.plan.volumes[0].lightVoxelFactor);
        Emax = 1.0 / (rMin * rMin);
    }
    const double diag = (c.generator == "box" ? std::sqrt(3.0) : 2.0) * c.size + 4 * c.voxel;
    const double lRay = double(c.sigma_s) * diag;
    const double omega = c.sigma_s / std::max(1e-30f, c.sigma_s + c.sigma_a);
    const double bound = l2plusBound(lRay, omega, angularBound(c.kernel, c.g, s.render.wkbOrderMax), Emax);
    expectFiniteNonNegativeBounded(r.film, bound, c.name);
    // Every case sees a lit part of its volume: L2+ is there, and it is exactly 0 without scattering.
    if (c.sigma_s == 0.0f)
        EXPECT_EQ(mean(aov(r.film, "L2plus")), 0.0) << c.name;
    else
        EXPECT_GT(mean(aov(r.film, "L2plus")), 0.0) << c.name;
}

INSTANTIATE_TEST_SUITE_P(
    Extremes, WkbStability,
    ::testing::Values(
        // optical thickness 1e4 per voxel (box of 16 voxels), albedo 0.99 and exactly 1
        StabilityCase{"tau1e4PerVoxel", "box", 1.0, 1.0 / 16, 1.6e5f * 0.99f, 1.6e3f, 0.6f, {0.3f, 3, 2.5f}},
        StabilityCase{"tau1e4PerVoxelAlbedo1", "box", 1.0, 1.0 / 16, 1.6e5f, 0.0f, 0.6f, {0.3f, 3, 2.5f}},
        // optical thickness 1e4 across the volume (156 per voxel)
        StabilityCase{"tau1e4PerVolume", "sphere", 0.5, 1.0 / 64, 1e4f, 0.0f, 0.8f, {0.2f, 0.3f, 4}},
        // albedo exactly 0 (L2+ must be 0) and exactly 1
        StabilityCase{"albedo0", "sphere", 1.0, 1.0 / 16, 0.0f, 5.0f, 0.5f, {0, 0, 5}},
        StabilityCase{"albedo1", "sphere", 1.0, 1.0 / 16, 5.0f, 0.0f, 0.5f, {0, 0, 5}},
        // HG g across the range, both kernels
        StabilityCase{"gMinus099", "sphere", 1.0, 1.0 / 16, 3.0f, 0.03f, -0.99f, {0, 0, 5}},
        StabilityCase{"gMinus05", "sphere", 1.0, 1.0 / 16, 3.0f, 0.03f, -0.5f, {0, 0, 5}},
        StabilityCase{"g0", "sphere", 1.0, 1.0 / 16, 3.0f, 0.03f, 0.0f, {0, 0, 5}},
        StabilityCase{"g05", "sphere", 1.0, 1.0 / 16, 3.0f, 0.03f, 0.5f, {0, 0, 5}},
        StabilityCase{"g09", "sphere", 1.0, 1.0 / 16, 3.0f, 0.03f, 0.9f, {0, 0, 5}},
        StabilityCase{"g099", "sphere", 1.0, 1.0 / 16, 3.0f, 0.03f, 0.99f, {0, 0, 5}},
        StabilityCase{
            "g099Exact", "sphere", 1.0, 1.0 / 16, 3.0f, 0.03f, 0.99f, {0, 0, 5}, false, wkb::KernelType::Exact},
        StabilityCase{
            "gMinus099Exact", "sphere", 1.0, 1.0 / 16, 3.0f, 0.03f, -0.99f, {0, 0, 5}, false, wkb::KernelType::Exact},
        // a point light inside the volume, and the camera inside the volume
        StabilityCase{"lightInside", "sphere", 1.0, 1.0 / 16, 4.0f, 0.04f, 0.7f, {0, 0, 5}, true},
        StabilityCase{"cameraInside", "sphere", 1.0, 1.0 / 16, 4.0f, 0.04f, 0.7f, {0.1f, 0.05f, 0.2f}},
        // world scales: a millimetre and a kilometre sphere with the same optical size (tau 4)
        StabilityCase{"millimetre", "sphere", 1e-3, 1e-3 / 16, 2e3f, 20.0f, 0.7f, {0, 0, 5e-3f}},
        StabilityCase{"kilometre", "sphere", 1e3, 1e3 / 16, 2e-3f, 2e-5f, 0.7f, {0, 0, 5e3f}}),
    [](const ::testing::TestParamInfo<StabilityCase>& i) { return std::string(i.param.name); });

// Scale invariance (issue 13, item 6: a target, not a loose bound). Radiative transfer has no
// length scale of its own: a sphere of radius R with coefficients sigma / R, seen from 5 R, gives
// the same image for every R. A millimetre and a kilometre sphere must render what the metre
// sphere renders, pixel by pixel, to float precision (the same random numbers, the same steps in
// units of the voxel): each pixel's L2+ within 1e-3 of the metre image's peak, the image means
// within 1e-4 relative. Orders 3+ by the kernel (a deterministic march): the traced cache, the
// default, is a Monte Carlo estimate whose light paths part ways at the first rounding that
// differs between scales (and VrlLightPass pads its disk of light-path origins by an absolute
// 1e-4 m, 5% of the millimetre sphere), so it is scale-invariant in expectation only: measured
// 2026-12-03, image mean -1.5% (mm) and +0.09% (km), worst pixel 9% and 1% of the peak.
TEST(WkbStability, MillimetreAndKilometreRenderTheMetreImage)
{
    auto renderAt = [](double R) {
        Scene s = baseScene(12, 12, make_float3(0, 0, float(5 * R)), make_float3(0, 0, 0), 40);
        s.render.wkbOrders3 = WkbOrders3::Kernel;
        s.volumes.push_back(proceduralVolume("sphere", {{"radius", R}, {"voxel_size", R / 16}},
                                             splat(float(2.0 / R)), splat(float(0.02 / R)), 0.7f));
        s.lights.push_back(sun(make_float3(0.3f, -1, 0.2f), 1.0f));
        return render(s);
    };
    RenderResult metre = renderAt(1.0);
    const Aov& ref = aov(metre.film, "L2plus");
    double peak = 0.0;
    for (float v : ref.pixels)
        peak = std::max(peak, double(v));
    ASSERT_GT(peak, 0.0);
    for (double R : {1e-3, 1e3}) {
        RenderResult r = renderAt(R);
        const Aov& l2 = aov(r.film, "L2plus");
        ASSERT_EQ(l2.pixels.size(), ref.pixels.size());
        double worst = 0.0;
        for (size_t i = 0; i < ref.pixels.size(); ++i)
            worst = std::max(worst, std::fabs(double(l2.pixels[i]) - double(ref.pixels[i])));
        EXPECT_LE(worst, 1e-3 * peak) << "R " << R;
        EXPECT_NEAR(mean(l2), mean(ref), 1e-4 * mean(ref)) << "R " << R;
    }
}

// Hand-made grids: densities from 1e-6 to 1e6 in one grid, a single active voxel, an empty grid.
TEST(WkbStabilityGrid, DensitiesSpanningTwelveDecades)
{
    Scene s = baseScene(12, 12, make_float3(0.2f, 0.3f, 4), make_float3(0.5f, 0.5f, 0.5f), 40);
    s.render.wkbOrders3 = WkbOrders3::Kernel;  // the bound below is the kernel's
    s.lights.push_back(sun(make_float3(0.3f, -1, 0.2f), 1.0f));
    Medium m;
    m.sigma_s = splat(0.99f);
    m.sigma_a = splat(0.01f);
    m.phase = NbPhase{0.8f, 0, 0, 0};
    auto rho = [](int i, int j, int k) {
        nb_uint h = nbPcgHash(nb_uint(i) * 73856093u ^ nb_uint(j) * 19349663u ^ nb_uint(k) * 83492791u);
        return float(std::pow(10.0, -6.0 + 12.0 * double(h >> 8) / 16777216.0));
    };
    auto ctx = handContext(s, {handMadeVolume(16, 1.0f / 16, make_float3(0, 0, 0), rho, m)});
    wkb::WkbIntegrator w(*ctx, ctx.plan, ctx.stats);
    ASSERT_TRUE(w.active());
    const double bound =
        l2plusBound(0.99e6 * std::sqrt(3.0), 0.99, angularBound(wkb::KernelType::Gaussian, 0.8f, 128), 1.0);
    double total = 0;
    for (Rgb v : marchL2plus(*ctx, w)) {
        ASSERT_TRUE(isFinite(v));
        ASSERT_GE(nbMinComponent(v), 0.0f);
        ASSERT_LE(nbMaxComponent(v), bound);
        total += nbAverage(v);
    }
    EXPECT_GT(total, 0.0);
}

TEST(WkbStabilityGrid, SingleActiveVoxelAndEmptyGrid)
{
    Scene s = baseScene(12, 12, make_float3(0.1f, 0.2f, 0.8f), make_float3(0, 0, 0), 60);
    s.render.wkbOrders3 = WkbOrders3::Kernel;  // the bound below is the kernel's
    s.lights.push_back(sun(make_float3(0.3f, -1, 0.2f), 1.0f));
    Medium m;
    m.sigma_s = splat(50.0f);
    m.phase = NbPhase{0.5f, 0, 0, 0};
    {
        auto ctx = handContext(s, {handMadeVolume(
                                      1, 0.1f, make_float3(0, 0, 0), [](int, int, int) { return 1.0f; }, m)});
        wkb::WkbIntegrator w(*ctx, ctx.plan, ctx.stats);
        const double bound =
            l2plusBound(50.0 * 0.2 * std::sqrt(3.0), 1.0, angularBound(wkb::KernelType::Gaussian, 0.5f, 128), 1.0);
        for (Rgb v : marchL2plus(*ctx, w)) {
            ASSERT_TRUE(isFinite(v));
            ASSERT_GE(nbMinComponent(v), 0.0f);
            ASSERT_LE(nbMaxComponent(v), bound);
        }
    }
    {
        auto ctx = handContext(s, {handMadeVolume(
                                      8, 0.1f, make_float3(0, 0, 0), [](int, int, int) { return 0.0f; }, m)});
        wkb::WkbIntegrator w(*ctx, ctx.plan, ctx.stats);
        EXPECT_FALSE(w.active());
        for (Rgb v : marchL2plus(*ctx, w))
            ASSERT_EQ(nbMaxComponent(v), 0.0f);
    }
}

// An optically thin scene is planned without L2+, and its bound is reported.
TEST(WkbRender, ThinSceneSkipsL2plusWithItsBound)
{
    Scene s = baseScene(8, 8, make_float3(0, 0, 5), make_float3(0, 0, 0), 40);
    s.volumes.push_back(
        proceduralVolume("sphere", {{"radius", 1.0}, {"voxel_size", 0.1}}, splat(1e-3f), splat(0.0f), 0.0f));
    s.lights.push_back(sun(make_float3(0, -1, 0), 1.0f));
    ASSERT_EQ(s.render.wkbOrders3, WkbOrders3::Traced) << "the default";
    RenderResult r = render(s);
    EXPECT_FALSE(r.plan.wkb.l2plus);
    EXPECT_LT(r.plan.wkb.l2plusBound, s.render.tolerance);
    EXPECT_EQ(mean(aov(r.film, "L2plus")), 0.0);
    // Nor is the traced cache built (its stage: "orders 2+" or "orders 3+ light paths"): nothing
    // would read it.
    for (const auto& stage : r.stats.stageSeconds)
        EXPECT_EQ(stage.first.find("light paths"), std::string::npos) << stage.first;
}

// The traced orders-3+ cache (the default) is planned only up to kTracedOrders3MaxDepth of optical
// depth per voxel: a conservative box at 1e4 per voxel took over 300 s with it (the light paths'
// collisions), and near the top of the extinction range its flights stop advancing
// (InputExtremes.ExtinctionAtTheTopOfTheRangeRendersFiniteAndPromptly). Past it the plan says so,
// no cache is traced and the render is the kernel's, pixel for pixel; under it the cache is traced.
TEST(WkbRender, TracedOrders3IsPlannedUpToItsDepthPerVoxel)
{
    auto boxAt = [](double depthPerVoxel) {
        Scene s = baseScene(8, 8, make_float3(0.3f, 3, 2.5f), make_float3(0, 0, 0), 40);
        const double voxel = 1.0 / 16;
        s.volumes.push_back(proceduralVolume("box", {{"size", 1.0}, {"voxel_size", voxel}},
                                             splat(float(depthPerVoxel / voxel)), splat(0.0f), 0.6f));
        s.lights.push_back(sun(make_float3(0.3f, -1, 0.2f), 1.0f));
        return s;
    };
    auto traced = [](const RenderResult& r) {
        for (const auto& stage : r.stats.stageSeconds)
            if (stage.first.find("light paths") != std::string::npos)
                return true;
        return false;
    };
    Scene thick = boxAt(1e4);
    ASSERT_EQ(thick.render.wkbOrders3, WkbOrders3::Traced) << "the default";
    const RenderResult r = render(thick);
    EXPECT_FALSE(traced(r));
    bool noted = false;
    for (const std::string& n : r.plan.notes)
        noted = noted || n.find("orders 3+ by the kernel, not traced") != std::string::npos;
    EXPECT_TRUE(noted) << r.plan.describe();
    thick.render.wkbOrders3 = WkbOrders3::Kernel;
    EXPECT_EQ(aov(r.film, "L2plus").pixels, aov(render(thick).film, "L2plus").pixels);
    EXPECT_GT(mean(aov(r.film, "L2plus")), 0.0);

    ASSERT_LT(0.5, wkb::kTracedOrders3MaxDepth);
    const RenderResult under = render(boxAt(0.5));
    EXPECT_TRUE(traced(under));
}

// Every pairing of the two traced parts of the lights' L2+ with the kernel (render.wkb_order2 x
// render.wkb_orders3) counts each order once. Writing K2, K3 for the kernel's order 2 and orders 3+,
// T2 for traced order 2 and C3 for the cache's orders 3+: (kernel, kernel) = K2 + K3, (traced,
// kernel) = T2 + K3, (traced, traced) = T2 + C3, (kernel, traced) = K2 + C3, so (kernel, traced) +
// (traced, kernel) = (kernel, kernel) + (traced, traced) exactly in expectation. The image means
// differ only by where each march's jitter falls (the four draw their numbers in different
// orders): held to 1% of L2+. Dropping the kernel's order 2 in (kernel, traced), which the l-march
// did before the kernel kept its N = 1 term alone there, misses by K2: 28% of L2+ here (measured
// 2026-12-03: kernel/traced 0.0288 instead of 0.0379).
TEST(WkbRender, EveryOrder2AndOrders3PairingCountsEachOrderOnce)
{
    double L2[2][2];  // [order 2 traced][orders 3+ traced]
    for (int o2 = 0; o2 < 2; ++o2)
        for (int o3 = 0; o3 < 2; ++o3) {
            Scene s = baseScene(32, 24, make_float3(0.4f, 0.3f, 5), make_float3(0, 0, 0), 30);
            s.volumes.push_back(proceduralVolume("sphere", {{"radius", 1.0}, {"voxel_size", 1.0 / 20}}, splat(3.0f),
                                                 splat(0.03f), 0.5f));
            s.lights.push_back(sun(make_float3(0.4f, -1, -0.3f), 2.0f));
            s.render.spp = 4;
            s.render.wkbOrder2 = o2 ? WkbOrder2::Traced : WkbOrder2::Kernel;
            s.render.wkbOrders3 = o3 ? WkbOrders3::Traced : WkbOrders3::Kernel;
            L2[o2][o3] = mean(aov(render(s).film, "L2plus"));
        }
    const double kernel2 = L2[0][0] - L2[1][0];  // K2 - T2, from the kernel's orders 3+
    std::printf("L2plus means: kernel/kernel %.5f traced/kernel %.5f kernel/traced %.5f traced/traced %.5f; "
                "K2 - T2 %.5f\n",
                L2[0][0], L2[1][0], L2[0][1], L2[1][1], kernel2);
    EXPECT_GT(L2[1][1], 0.0);
    EXPECT_NEAR(L2[0][1] + L2[1][0], L2[0][0] + L2[1][1], 0.01 * L2[0][0]);

    // render.wkb_order2 "cache": orders 2+ from the cache (C2 + C3), the same orders as traced/traced
    // (T2 + C3), held to the 5% of issue 13's L2plus target (C2 and T2 are different estimators of
    // order 2: the cache's cells against a point per camera ray). Without a cache (orders 3+ by
    // the kernel) order 2 is traced: the traced/kernel render exactly.
    Scene s = baseScene(32, 24, make_float3(0.4f, 0.3f, 5), make_float3(0, 0, 0), 30);
    s.volumes.push_back(proceduralVolume("sphere", {{"radius", 1.0}, {"voxel_size", 1.0 / 20}}, splat(3.0f),
                                         splat(0.03f), 0.5f));
    s.lights.push_back(sun(make_float3(0.4f, -1, -0.3f), 2.0f));
    s.render.spp = 4;
    s.render.wkbOrder2 = WkbOrder2::Cache;
    const double cached = mean(aov(render(s).film, "L2plus"));
    std::printf("L2plus mean with order 2 from the cache %.5f (traced/traced %+.4f relative)\n", cached,
                cached / L2[1][1] - 1.0);
    EXPECT_NEAR(cached, L2[1][1], 0.05 * L2[1][1]);
    s.render.wkbOrders3 = WkbOrders3::Kernel;
    EXPECT_DOUBLE_EQ(mean(aov(render(s).film, "L2plus")), L2[1][0]);
}

// Energy balance (issue 13, item 6: a closed form, not a one-sided bound): a homogeneous sphere of
// radius R, optical radius 10, albedo exactly 1, under a sun of irradiance E absorbs nothing, so
// everything it intercepts leaves it again: the power scattered out equals the intercepted power
// E int (1 - e^{-tau(x, z)}) dx dz over the sun's beam (tau the optical depth of the line through
// (x, z), here from the volume itself, so the procedural sphere's one-voxel soft edge is counted
// exactly). The scattered power is the image-plane integral of radiance (sum of pixel radiance x
// pixel area at the sphere) toward a far camera at angle theta from the sun's direction of travel;
// by the symmetry about the sun's axis it is 2 pi int_{-1}^{1} I(mu) dmu, here by 6-point
// Gauss-Legendre (Boost.Math's nodes and weights). Light that crosses unscattered (e^{-20} on the
// axis, more near the edge) is in neither: the beauty of a far camera in the sun's own direction
// would see it as L0 only where the sun is a point, so it is left out of both sides. The target
// is issue 13's for a thick medium (its thick half-space: within 10% of the exact answer). With
// orders 3+ by the kernel it measured 0.945 on 2026-12-02 (L2plus 85% of the output, so L2plus
// about 6.5% low, outside the tighter L2plus target of +-5%); with the traced cache, the default
// since 2026-12-03, 1.001 (L2plus 86%; docs/validation.md).
TEST(WkbEnergy, ThickConservativeSphereGivesBackWhatItIntercepts)
{
    const double R = 1.0, voxel = R / 16, E = 1.0, distance = 40.0;
    // Boost stores the non-negative half of the rule: nodes +-t[i], weights w[i].
    const auto &t = boost::math::quadrature::gauss<double, 6>::abscissa(),
               &tw = boost::math::quadrature::gauss<double, 6>::weights();
    const double nodes[6] = {-t[2], -t[1], -t[0], t[0], t[1], t[2]};
    const double weights[6] = {tw[2], tw[1], tw[0], tw[0], tw[1], tw[2]};
    const int res = 40;
    const double fov = 2.0 * std::atan(1.15 * R / distance) * 180.0 / M_PI;
    const double pixelArea = std::pow(2.0 * distance * std::tan(0.5 * fov * M_PI / 180.0) / res, 2.0);
    double power = 0.0, powerL2 = 0.0;
    double intercepted = 0.0;
    for (int k = 0; k < 6; ++k) {
        // mu = cos(angle between the sun's travel direction (0,-1,0) and the direction to the camera)
        const double mu = nodes[k], st = std::sqrt(1.0 - mu * mu);
        const float3 toCamera = make_float3(float(st), float(-mu), 0.0f);
        Scene s = baseScene(res, res, toCamera * float(distance), make_float3(0, 0, 0), float(fov));
        s.camera.up = make_float3(0, 0, 1);
        s.volumes.push_back(
            proceduralVolume("sphere", {{"radius", R}, {"voxel_size", voxel}}, splat(10.0f), splat(0.0f), 0.5f));
        s.lights.push_back(sun(make_float3(0, -1, 0), float(E)));
        s.render.spp = 1;
        if (k == 0) {
            // The intercepted power: lines along the sun through a grid of (x, z), 100 per radius.
            auto ctx = RenderContext::create(s, false);
            const int n = 230;
            const double h = 2.3 * R / n;
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    const float3 o = make_float3(float(-1.15 * R + (i + 0.5) * h), float(3 * R),
                                                 float(-1.15 * R + (j + 0.5) * h));
                    const Rgb tau = ctx->volumes.opticalDepth(o, make_float3(0, -1, 0), 0.0f, float(6 * R), 0.25f);
                    intercepted += E * -std::expm1(-double(nbAverage(tau))) * h * h;
                }
        }
        RenderResult r = render(s);
        const Aov& b = aov(r.film, "beauty");
        const Aov& l2 = aov(r.film, "L2plus");
        double I = 0, I2 = 0;
        for (size_t p = 0; p < b.pixels.size() / 4; ++p) {
            I += (b.pixels[4 * p] + b.pixels[4 * p + 1] + b.pixels[4 * p + 2]) / 3.0 * pixelArea;
            I2 += (l2.pixels[3 * p] + l2.pixels[3 * p + 1] + l2.pixels[3 * p + 2]) / 3.0 * pixelArea;
        }
        power += 2 * M_PI * weights[k] * I;
        powerL2 += 2 * M_PI * weights[k] * I2;
    }
    RecordProperty("outgoing_over_intercepted", std::to_string(power / intercepted));
    RecordProperty("l2plus_share", std::to_string(powerL2 / std::max(power, 1e-30)));
    std::printf("energy: outgoing / intercepted = %.3f (intercepted %.4f W, pi R^2 E = %.4f W; L2+ %.0f%% of the "
                "output)\n",
                power / intercepted, intercepted, M_PI * R * R * E, 100.0 * powerL2 / power);
    EXPECT_NEAR(power / intercepted, 1.0, 0.10);
    EXPECT_GT(powerL2, 0.0);
}

namespace {

// A hand-made grid of n^3 voxels holding f(i, j, k) (channels values per voxel), as handMadeVolume.
template <class F>
void fillGrid(BrickGrid& g, int n, int channels, F f)
{
    int nb = (n + BrickGrid::kBrick) / BrickGrid::kBrick + 1;
    g.reset({-1, -1, -1}, {nb, nb, nb}, channels);
    for (int bz = 0; bz < nb; ++bz)
        for (int by = 0; by < nb; ++by)
            for (int bx = 0; bx < nb; ++bx) {
                float* vals = g.allocateBrick(bx, by, bz);
                for (int z = 0; z < BrickGrid::kStored; ++z)
                    for (int y = 0; y < BrickGrid::kStored; ++y)
                        for (int x = 0; x < BrickGrid::kStored; ++x) {
                            int i = (bx - 1) * 8 + x, j = (by - 1) * 8 + y, k = (bz - 1) * 8 + z;
                            bool inside = i >= 0 && j >= 0 && k >= 0 && i < n && j < n && k < n;
                            for (int c = 0; c < channels; ++c)
                                vals[((z * BrickGrid::kStored + y) * BrickGrid::kStored + x) * channels + c] =
                                    inside ? f(i, j, k, c) : 0.0f;
                        }
            }
    g.pruneZeroBricks();
}

}  // namespace

// An environment light is an SH source: its level-0 coefficients are L0's projection. In a cube
// of optical half-width 0.05 the centre sees the sky's radiance L attenuated by e^{-tau} over
// directions, so L^00 = sqrt(4 pi) L <e^{-tau}> lies between sqrt(4 pi) L e^{-0.05 sqrt 3} and
// sqrt(4 pi) L e^{-0.05}, and the order-1 coefficients vanish by symmetry (to the 32-sample
// stratified estimate's residual, a few percent of L^00 times tau). The render is finite and
// non-negative and has L2+.
TEST(WkbSources, EnvironmentLightProjectsToSh)
{
    Scene s = baseScene(8, 8, make_float3(0.3f, 0.2f, 3.0f), make_float3(0.5f, 0.5f, 0.5f), 40);
    Light env;
    env.name = "sky";
    env.type = LightType::Environment;
    env.radiance = make_float3(1.0f, 2.0f, 3.0f);
    s.lights.push_back(env);
    s.render.wkbShOrderMax = 1;
    s.render.wkbOrders3 = WkbOrders3::Kernel;  // the kernel's SH light volume is what is checked
    Medium m;
    m.sigma_s = splat(0.1f);
    m.phase = NbPhase{0.6f, 0, 0, 0};  // p_1 != 0, so that order 1 is worth keeping
    auto ctx = handContext(s, {handMadeVolume(
                                  32, 1.0f / 32, make_float3(0, 0, 0), [](int, int, int) { return 1.0f; }, m)});
    wkb::WkbIntegrator w(*ctx, ctx.plan, ctx.stats);
    ASSERT_TRUE(w.active());
    const wkb::SourcePlan& sp = w.setup().sources[0];
    ASSERT_EQ(sp.mode, wkb::SourceMode::Sh);
    ASSERT_EQ(sp.order, 1);
    const wkb::VolumeSetup& vs = w.setup().volumes[0];
    // The light voxel at the cube's centre (density index 15.5 -> light index (15.5 - origin) / f).
    const float q = (15.5f - vs.origin.x) / float(vs.factor);
    std::vector<float> ch(size_t(w.setup().channels), 0.0f);
    w.lightVolumes().pyramid(0).fetchLevel(0, make_float3(q, q, q), 0, w.setup().channels, 1.0f, ch.data());
    ASSERT_GT(ch[0], 0.0f);
    const float L00 = ch[sp.offset + 1] / ch[0];  // green
    const float norm = std::sqrt(4.0f * float(M_PI)) * 2.0f;
    EXPECT_GE(L00, norm * std::exp(-0.05f * std::sqrt(3.0f)) * 0.999f);
    EXPECT_LE(L00, norm * std::exp(-0.05f) * 1.001f);
    for (int jm = 1; jm < 4; ++jm)
        EXPECT_LT(std::fabs(ch[sp.offset + 3 * jm + 1] / ch[0]), 0.02f * L00) << jm;
    double total = 0;
    for (Rgb v : marchL2plus(*ctx, w)) {
        ASSERT_TRUE(isFinite(v));
        ASSERT_GE(nbMinComponent(v), 0.0f);
        total += v.y;
    }
    EXPECT_GT(total, 0.0);
}

// Emission as a light source (Tessendorf sec. 3.4.4): deep inside a homogeneous medium with
// uniform emission S (W/(m^3 sr)), extinction c and albedo omega0, every order is known: L0 =
// S/c and L2+ = omega0^2 / (1 - omega0) S/c (the weight's integral, eq. 88 with an isotropic
// source). With isotropic scattering (only order 0 enters) WKB reads the blurred unscattered
// emission's mean over directions, S/c in the interior, with weights summing to
// omega0^2/(1 - omega0): here the model is exact, and the faces, 30 optical depths away, change
// it by less than e^{-30}. What is left is the emission light volume's direction sampling and
// the pyramid's float sums: held to 0.5% (measured 0.12% low; issue 13's L2plus energy target
// is 5%). There are no lights: L2+ goes to L2plus alone.
TEST(WkbSources, EmissionFeedsL2plusDeepInsideAMedium)
{
    const int n = 48;
    const float voxel = 1.0f / n, c = 60.0f, omega = 0.5f, S = 2.0f;  // optical half-width 30
    Scene s = baseScene(4, 4, make_float3(0.5f, 0.5f, 0.5f), make_float3(0.5f, 0.5f, 1.0f), 10);
    s.render.wkbOrders3 = WkbOrders3::Kernel;  // handContext's (emission keeps the kernel either way)
    Medium m;
    m.sigma_s = splat(omega * c);
    m.sigma_a = splat((1 - omega) * c);
    m.phase = NbPhase{0.0f, 0, 0, 0};
    auto vol = handMadeVolume(
        n, voxel, make_float3(0, 0, 0), [](int, int, int) { return 1.0f; }, m);
    fillGrid(vol->emission, n, 3, [&](int, int, int, int) { return S; });
    vol->emission.updateMajorants();
    auto ctx = handContext(s, {vol});
    wkb::WkbIntegrator w(*ctx, ctx.plan, ctx.stats);
    ASSERT_TRUE(w.active());
    ASSERT_EQ(w.setup().sources.size(), 1u);
    EXPECT_TRUE(w.setup().sources[0].emission);
    const double exact = omega * omega / (1 - omega) * S / c;
    for (Rgb v : marchL2plus(*ctx, w)) {
        ASSERT_TRUE(isFinite(v));
        EXPECT_NEAR(v.y, exact, 5e-3 * exact);
    }
}

// Two overlapping volumes with different media and phase functions (a forward-scattering cloud
// through an isotropic haze): the march mixes their phase moments by scattering and reads both
// pyramids; the image is finite and non-negative, L2+ is there, and the plan names both grids.
TEST(WkbRender, OverlappingVolumesMix)
{
    Scene s = baseScene(16, 12, make_float3(0, 0.3f, 5), make_float3(0, 0, 0), 35);
    s.volumes.push_back(
        proceduralVolume("cloud", {{"radius", 0.8}, {"voxel_size", 0.05}}, splat(5.0f), splat(0.05f), 0.85f));
    Volume haze = proceduralVolume("box", {{"size", 2.0}, {"voxel_size", 0.1}}, make_float3(0.3f, 0.4f, 0.6f),
                                   splat(0.02f), 0.0f);
    haze.name = "haze";
    s.volumes.push_back(haze);
    s.lights.push_back(sun(make_float3(0.3f, -1, 0.2f), 2.0f));
    s.render.wkbOrders3 = WkbOrders3::Kernel;  // the kernel's march is what reads the pyramids
    RenderResult r = render(s);
    expectFiniteNonNegativeBounded(r.film, 1e30, "overlap");
    EXPECT_GT(mean(aov(r.film, "L2plus")), 0.0);
    ASSERT_EQ(r.stats.volumes.size(), 2u);
    EXPECT_GT(r.stats.volumes[0].pyramidBytes, 0u);
    EXPECT_GT(r.stats.volumes[1].pyramidBytes, 0u);
}

// Where both of a light's parts of L2+ are traced (order 2 per camera ray or in the cache, orders
// 3+ in the radiance cache: the defaults), nothing reads its light volume: none is built, nor a
// shadow map of its own (a soft sun's), and without emission no pyramid at all; with emission the
// pyramids hold the density and emission's channels only. (A sky's 32 shadow rays per light
// voxel were 95% of a 1024-across cloud's render before: docs/benchmarks.md "Scale".)
TEST(WkbRender, TracedLightsBuildNoLightVolumes)
{
    Scene s = baseScene(16, 12, make_float3(0, 0.3f, 5), make_float3(0, 0, 0), 35);
    s.volumes.push_back(
        proceduralVolume("cloud", {{"radius", 0.8}, {"voxel_size", 0.05}}, splat(5.0f), splat(0.05f), 0.6f));
    Light soft = sun(make_float3(0.3f, -1, 0.2f), 2.0f);
    soft.angle = 0.53f;
    s.lights.push_back(soft);
    Light sky;
    sky.name = "sky";
    sky.type = LightType::Environment;
    sky.radiance = make_float3(0.1f, 0.2f, 0.4f);
    s.lights.push_back(sky);
    RenderResult r = render(s);
    EXPECT_FALSE(r.plan.wkb.lightGrid);
    EXPECT_EQ(r.plan.wkb.pyramidBytes, 0u);
    EXPECT_EQ(r.stats.pyramidBytes, 0u);
    ASSERT_EQ(r.stats.lights.size(), 2u);
    EXPECT_EQ(r.stats.lights[0].l2plusShadowMapBytes, 0u);
    EXPECT_GT(mean(aov(r.film, "L2plus")), 0.0);
    for (const char* light : {"light_sun", "light_sky"})
        EXPECT_GT(mean(aov(r.film, light)), 0.0) << light;
    EXPECT_NE(r.plan.describe().find("no light volumes: every source is traced"), std::string::npos)
        << r.plan.describe();
}

// render.wkb_order2 "auto" (the default; docs/wkb.md "Which order-2 model"): order 2 from the
// radiance cache unless a light's single scattering has an edge the cache's cells would spread: a
// spot's cone edge, or a shadow caster's shadows. A sun, a point light inside the medium and one
// outside it, a sphere light and an environment light take the cache; a spot light far off and a
// sun with a shadow-casting ball above the medium do not (a ball that only holds out does). Then
// auto renders exactly what the model it chose renders.
TEST(WkbRender, AutoOrder2TakesTheCacheUnlessALightHasAnEdge)
{
    auto scene = [](const Light& light) {
        Scene s = baseScene(24, 16, make_float3(0.4f, 0.3f, 5), make_float3(0, 0, 0), 30);
        s.volumes.push_back(
            proceduralVolume("sphere", {{"radius", 1.0}, {"voxel_size", 1.0 / 20}}, splat(3.0f), splat(0.03f), 0.5f));
        s.lights.push_back(light);
        s.render.spp = 2;
        return s;
    };
    auto positioned = [](LightType type, float3 p) {
        Light l;
        l.name = "lamp";
        l.type = type;
        l.position = p;
        l.direction = normalize(-p);
        return l;
    };
    Light sky;
    sky.name = "sky";
    sky.type = LightType::Environment;
    struct Case {
        const char* what;
        Light light;
        bool cache;
    } cases[] = {
        {"sun", sun(make_float3(0.4f, -1, -0.3f), 2.0f), true},
        {"point light 3 m out", positioned(LightType::Point, make_float3(0, 3, 0)), true},
        {"point light inside", positioned(LightType::Point, make_float3(0.2f, 0.1f, 0)), true},
        {"sphere light", positioned(LightType::Sphere, make_float3(0, 2.5f, 0)), true},
        {"environment light", sky, true},
        {"spot light 3 m out", positioned(LightType::Spot, make_float3(0, 3, 0)), false},
    };
    for (const Case& c : cases) {
        const Scene s = scene(c.light);
        std::unique_ptr<RenderContext> ctx = RenderContext::create(s, false);
        const wkb::Order2Choice choice = wkb::chooseOrder2(*ctx);
        EXPECT_EQ(choice.cache, c.cache) << c.what << ": " << choice.reason;
    }
    // The sun again, with a ball that casts shadows into the medium (and one that only holds out).
    for (bool shadows : {true, false}) {
        Scene s = scene(cases[0].light);
        Geometry ball;
        ball.name = "ball";
        ball.type = GeometryType::Sphere;
        ball.radius = 0.3f;
        ball.transform = Transform::translate(0.0, 1.6, 0.0);
        ball.holdout = !shadows, ball.shadows = shadows;
        s.geometry.push_back(ball);
        std::unique_ptr<RenderContext> ctx = RenderContext::create(s, false);
        EXPECT_EQ(wkb::chooseOrder2(*ctx).cache, !shadows) << (shadows ? "shadow caster" : "holdout only");
    }
    for (const Case& c : {cases[0], cases[5]}) {
        Scene s = scene(c.light);
        s.render.wkbOrder2 = WkbOrder2::Auto;
        const RenderResult automatic = render(s);
        s.render.wkbOrder2 = c.cache ? WkbOrder2::Cache : WkbOrder2::Traced;
        const RenderResult chosen = render(s);
        EXPECT_EQ(aov(automatic.film, "L2plus").pixels, aov(chosen.film, "L2plus").pixels) << c.what;
        EXPECT_GT(mean(aov(chosen.film, "L2plus")), 0.0) << c.what;
    }
}
