// Determinism (STYLE rule 7), progressive rendering and stopping rules: the same seed gives
// the same bits whatever the work-group size or the split into launches; a checkpoint after k
// samples is the image of a k-sample render; time limits and cancellation stop the render.
#include "PtWorld.h"

#include "core/Error.h"
#include "pathtracer/OpenCl.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <thread>
#include <tuple>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

// Every feature the kernel specialises on: two overlapping volumes (one emitting, one with a
// two-lobe phase function), RGB media, and one light of every type.
World featureWorld(bool emission = true)
{
    World w(16, 12);
    w.volumes.push_back(boxVolume(
        make_float3(-1, -1, -1), make_float3(1, 1, 1), {2, 2, 2},
        medium(make_float3(2, 3, 4), make_float3(0.2f, 0.1f, 0.3f), NbPhase{0.5f, 0, 0, 0}),
        [](float3 u) { return 0.2f + u.x * u.y + 0.5f * u.z * u.z; },
        emission ? std::function<Rgb(float3)>([](float3 u) { return make_float3(u.x, 0.2f, u.z); }) : nullptr));
    w.volumes.push_back(boxVolume(make_float3(-0.2f, -1.2f, -0.5f), make_float3(1.4f, 0.4f, 1.1f), {1, 1, 1},
                                  medium(splat(1.5f), splat(0.5f), NbPhase{0.8f, -0.3f, 0.25f, 0}),
                                  [](float3 u) { return u.y; }));
    w.addLight(distantLight(make_float3(0.3f, -1, -0.2f), make_float3(2, 2, 1.5f)));
    Light point;
    point.type = LightType::Point;
    point.position = make_float3(0.5f, 1.5f, 1.0f);
    point.intensity = splat(3.0f);
    w.addLight(point);
    Light spot;
    spot.type = LightType::Spot;
    spot.position = make_float3(-2, 0.5f, 1);
    spot.direction = normalize(make_float3(1, -0.2f, -0.5f));
    spot.intensity = splat(5.0f);
    w.addLight(spot);
    Light rect;
    rect.type = LightType::Rect;
    rect.center = make_float3(0, -2, 0);
    rect.normal = make_float3(0, 1, 0);
    rect.size[0] = rect.size[1] = 1.5f;
    rect.radiance = splat(2.0f);
    w.addLight(rect);
    Light sphere;
    sphere.type = LightType::Sphere;
    sphere.position = make_float3(1.5f, 0.5f, -1.5f);
    sphere.radius = 0.3f;
    sphere.radiance = splat(4.0f);
    w.addLight(sphere);
    w.addLight(environmentLight(make_float3(0.1f, 0.15f, 0.2f)));
    lookAt(w.scene, make_float3(0.5f, 0.8f, 4.5f), make_float3(0, 0, 0), 40);
    w.scene.camera.crop[0] = 0.1f;
    w.scene.camera.crop[1] = 0.9f;
    w.scene.camera.crop[2] = 0.2f;
    w.scene.camera.crop[3] = 1.0f;
    w.scene.render.maxDepth = 12;
    w.scene.render.spp = 6;
    w.scene.render.seed = 5;
    return w;
}

void expectIdentical(const Film& a, const Film& b, const char* what)
{
    ASSERT_EQ(a.aovs.size(), b.aovs.size());
    for (size_t i = 0; i < a.aovs.size(); ++i) {
        ASSERT_EQ(a.aovs[i].name, b.aovs[i].name);
        ASSERT_EQ(a.aovs[i].pixels.size(), b.aovs[i].pixels.size());
        size_t differing = 0;
        for (size_t k = 0; k < a.aovs[i].pixels.size(); ++k)
            differing += std::memcmp(&a.aovs[i].pixels[k], &b.aovs[i].pixels[k], sizeof(float)) != 0;
        EXPECT_EQ(differing, 0u) << what << ": AOV " << a.aovs[i].name;
    }
}

}  // namespace

TEST(PathtraceDeterminism, SameSeedSameBitsAnyWorkGroupSizeAndLaunchSplit)
{
    useTestKernelCache("determinism");
    World w = featureWorld();
    PathtraceStats stats;
    PathtraceOptions base;
    base.stats = &stats;
    Film reference = w.render(base);
    EXPECT_EQ(stats.samplesPerPixel, 6);
    EXPECT_EQ(stats.badSamples, 0);
    std::printf("kernel: %s\n", stats.defines.c_str());

    PathtraceOptions again = base;
    Film second = w.render(again);
    EXPECT_TRUE(stats.kernelFromCache) << "the second build should load the cached binary";
    expectIdentical(reference, second, "same seed");

    for (size_t local : {size_t(1), size_t(7), size_t(64)})
        for (int perPass : {1, 4}) {
            PathtraceOptions o;
            o.localSize = local;
            o.samplesPerPass = perPass;
            Film f = w.render(o);
            std::string what =
                "local size " + std::to_string(local) + ", " + std::to_string(perPass) + " spp per launch";
            expectIdentical(reference, f, what.c_str());
        }
    PathtraceOptions runtime;
    runtime.runtimeWorkGroupSize = true;
    expectIdentical(reference, w.render(runtime), "the runtime's work-group size");

    // Bounded launches (LaunchSize.h): ranges of a few items and a budget of a few steps per
    // sample stop most paths mid-way (between flights, at null collisions), and the next launch
    // continues them from their saved state; the bits are those of unbounded launches.
    for (auto [local, items, steps, perPass] : {std::tuple{size_t(1), size_t(5), 1, 1}, std::tuple{size_t(7), size_t(7), 3, 4},
                                                std::tuple{size_t(64), size_t(64), 16, 3}}) {
        PathtraceStats bounded;
        PathtraceOptions o;
        o.localSize = local;
        o.rangeItems = items;
        o.stepsPerSample = steps;
        o.samplesPerPass = perPass;
        o.stats = &bounded;
        Film f = w.render(o);
        std::string what = "ranges of " + std::to_string(items) + " items, " + std::to_string(steps) +
                           " steps per sample, " + std::to_string(perPass) + " spp per pass";
        expectIdentical(reference, f, what.c_str());
        std::printf("%s: %lld launches, %lld paths stopped and continued\n", what.c_str(), bounded.launches,
                    bounded.stoppedPaths);
        EXPECT_GT(bounded.stoppedPaths, 0) << what;
    }

    // The chosen launch (LaunchSize.h) gives every compute unit a work-group.
    const size_t units = size_t(ocl::selectDevice("").computeUnits);
    const Aov* beauty = reference.find("beauty");
    const size_t pixels = size_t(reference.x1 - reference.x0) * size_t(reference.y1 - reference.y0);
    ASSERT_NE(beauty, nullptr);
    std::printf("launch: %zu work-groups of %zu for %zu pixels on %zu compute units\n", stats.workGroups,
                stats.localSize, pixels, units);
    EXPECT_GE(stats.workGroups, std::min(units, pixels));
    EXPECT_GE(stats.workGroups * stats.localSize, pixels);

    w.scene.render.seed = 6;
    Film other = w.render();
    const Aov* a = reference.find("beauty");
    const Aov* b = other.find("beauty");
    size_t differing = 0;
    for (size_t k = 0; k < a->pixels.size(); ++k)
        differing += a->pixels[k] != b->pixels[k];
    EXPECT_GT(differing, a->pixels.size() / 2) << "another seed must give another image";

    // Sanity of the film: finite and non-negative; the crop window only.
    for (const Aov& aov : reference.aovs)
        for (float v : aov.pixels) {
            ASSERT_TRUE(std::isfinite(v)) << aov.name;
            ASSERT_GE(v, 0.0f) << aov.name;
        }
    EXPECT_EQ(pixel1(reference, "alpha", 0, 0), 0.0f);  // outside the crop: untouched
    EXPECT_GT(nbAverage(pixel3(reference, "beauty", 8, 6)), 0.0f);
}

// Without emission, the per-light AOVs split L1 + L2plus between the lights.
TEST(PathtraceDeterminism, LightAovsSumToScatteredLight)
{
    useTestKernelCache("determinism");
    World w = featureWorld(false);
    Film f = w.render();
    double worst = 0, scale = 0;
    for (int y = f.y0; y < f.y1; ++y)
        for (int x = f.x0; x < f.x1; ++x) {
            Rgb sum = splat(0.0f);
            for (const Light& l : w.scene.lights)
                sum += pixel3(f, "light_" + l.name, x, y);
            Rgb scattered = pixel3(f, "L1", x, y) + pixel3(f, "L2plus", x, y);
            worst = std::max(worst, double(nbMaxComponent(fmax(sum - scattered, scattered - sum))));
            scale = std::max(scale, double(nbMaxComponent(scattered)));
        }
    EXPECT_LT(worst, 1e-5 * std::max(1.0, scale));
}

// A checkpoint after k samples holds exactly the image of a k-sample render: the running
// estimate is the same sequence of updates.
TEST(PathtraceProgressive, CheckpointsAreTheRunningEstimate)
{
    useTestKernelCache("determinism");
    World w = featureWorld();
    w.scene.render.spp = 3;
    std::vector<Film> checkpoints;
    PathtraceOptions o;
    o.samplesPerPass = 1;
    o.checkpointSeconds = 1e-9;
    o.onCheckpoint = [&](const Film& f) { checkpoints.push_back(f); };
    Film final = w.render(o);
    ASSERT_EQ(checkpoints.size(), 2u);  // after samples 1 and 2; the final image is not a checkpoint
    for (int k = 1; k <= 2; ++k) {
        w.scene.render.spp = k;
        Film f = w.render();
        f.metadata.clear();
        checkpoints[size_t(k - 1)].metadata.clear();
        expectIdentical(f, checkpoints[size_t(k - 1)], ("checkpoint " + std::to_string(k)).c_str());
    }
}

TEST(PathtraceProgressive, TimeLimitStopsAfterTheLaunchThatCrossesIt)
{
    useTestKernelCache("determinism");
    World w = featureWorld();
    w.scene.render.spp = 0;  // no sample budget: the time limit alone stops the render
    w.scene.render.noiseTarget = 0;
    w.scene.render.timeLimit = 0.3;
    PathtraceStats stats;
    PathtraceOptions o;
    o.stats = &stats;
    o.samplesPerPass = 1;
    auto t0 = std::chrono::steady_clock::now();
    Film f = w.render(o);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_GE(stats.renderSeconds, 0.3);
    // At least the launch that crossed the limit; how many fit before it depends on the
    // machine's load (one launch can take 0.3 s on a busy CI machine), so no more is asserted.
    EXPECT_GE(stats.samplesPerPixel, 1);
    EXPECT_LT(seconds, 30.0);
    std::printf("time limit 0.3 s: %lld spp in %.2f s\n", stats.samplesPerPixel, stats.renderSeconds);
}

namespace {

// The noise target's measure from a film: mean over the crop of variance / (y^2 + eps), y the
// channel average of beauty, eps = (0.1 mean y)^2.
double filmNoiseRelMse(const Film& f)
{
    std::vector<double> y, var;
    for (int py = f.y0; py < f.y1; ++py)
        for (int px = f.x0; px < f.x1; ++px) {
            y.push_back(nbAverage(pixel3(f, "beauty", px, py)));
            var.push_back(pixel1(f, "variance", px, py));
        }
    double mean = 0;
    for (double v : y)
        mean += v / double(y.size());
    const double eps = 0.01 * mean * mean + 1e-20;
    double sum = 0;
    for (size_t i = 0; i < y.size(); ++i)
        sum += var[i] / (y[i] * y[i] + eps);
    return sum / double(y.size());
}

}  // namespace

// spp 0 (the default) renders until the beauty's relMSE from its variance reaches noise_target:
// the launch that stops is the first to reach it, and the film says so too.
TEST(PathtraceProgressive, NoiseTargetStopsAtTheFirstLaunchThatReachesIt)
{
    useTestKernelCache("determinism");
    World w = featureWorld();
    w.scene.render.spp = 0;
    w.scene.render.noiseTarget = 2e-3;
    PathtraceStats stats;
    PathtraceOptions o;
    o.stats = &stats;
    o.samplesPerPass = 8;
    Film f = w.render(o);
    const double measured = filmNoiseRelMse(f);
    std::printf("noise target 2e-3: %lld spp, relMSE %.3g (film %.3g)\n", stats.samplesPerPixel, stats.noiseRelMse,
                measured);
    EXPECT_GE(stats.samplesPerPixel, 64);
    EXPECT_LE(stats.noiseRelMse, 2e-3);
    EXPECT_NEAR(measured, stats.noiseRelMse, 1e-3 * stats.noiseRelMse);
    if (stats.samplesPerPixel > 64) {
        // The same render 8 samples shorter (bit for bit its prefix) had not reached the target.
        w.scene.render.spp = int(stats.samplesPerPixel) - 8;
        EXPECT_GT(filmNoiseRelMse(w.render()), 2e-3);
    }
}

// Cancel within a second whatever a sample costs (issue 18, item 3): at an extinction of
// ~10^5 1/m and albedo 0.99999, where a path scatters thousands of times and tracks six shadow
// rays each time, one sample of this 64x48 image took 5 s in one launch (measured with the
// launch bounds lifted: rangeItems 2^20, stepsPerSample 2^30); the bounded launches stop
// paths at their step budget (longest launch 0.3 s), so a cancel raised 0.5 s in ends the
// render within a second of it.
TEST(PathtraceProgressive, CancelWithinASecondAtExtremeExtinction)
{
    useTestKernelCache("determinism");
    World w = featureWorld(false);
    w.scene.render.maxDepth = 0;
    w.scene.camera.width = 64;
    w.scene.camera.height = 48;
    // First the same kernel and image at the medium's own extinction: the kernel's build or cache
    // load, and PoCL's compile for this work-group size on its first launch (seconds each on cold
    // caches), so that the cancel below lands in the launches.
    w.scene.render.spp = 1;
    w.render();
    for (auto& v : w.volumes) {
        v->medium.sigma_s = v->medium.sigma_s * 1e5f;
        v->medium.sigma_a = v->medium.sigma_s * 1e-5f;
    }
    w.scene.render.spp = 64;
    std::atomic<bool> cancel{false};
    RenderControl options;
    options.cancel = &cancel;
    PathtraceOptions o;
    Film film;
    std::thread canceller([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
        cancel = true;
    });
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_THROW(renderPathtrace(w.context(), film, options, o), Cancelled);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    canceller.join();
    std::printf("cancel at 0.5 s: returned after %.2f s\n", seconds);
    EXPECT_LT(seconds, 1.5);
}

TEST(PathtraceProgressive, CancelThrowsCancelled)
{
    useTestKernelCache("determinism");
    World w = featureWorld();
    w.scene.render.spp = 1000000;
    std::atomic<bool> cancel{true};
    RenderControl options;
    options.cancel = &cancel;
    Film film;
    EXPECT_THROW(renderPathtrace(w.context(), film, options, PathtraceOptions{}), Cancelled);
    RenderControl stopByProgress;
    int calls = 0;
    stopByProgress.progress = [&](float) { return ++calls < 3; };
    Film film2;
    EXPECT_THROW(renderPathtrace(w.context(), film2, stopByProgress, PathtraceOptions{}), Cancelled);
    EXPECT_EQ(calls, 3);
}
