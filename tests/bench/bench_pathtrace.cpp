// bench_pathtrace: path samples per second of the OpenCL path tracer on a procedural 128^3
// cloud, with the brick majorant grid (local majorants, DDA) and with one global majorant per
// volume, the same seed and samples for both. Built with the tests, never run by ctest.
//
//   bench_pathtrace [spp=16] [size=128] [device=""] [cloud=dense|wispy]
//   bench_pathtrace [spp=16] [size=128] [device=""] launch [rounds=3]
//   bench_pathtrace [spp=16] [size=128] [device=""] pnanovdb [rounds=5]
//   bench_pathtrace [spp=16] [size=128] [device=""] bounded [rounds=3]
//
// "launch" compares, on the dense cloud at the default max_depth (unbounded), the OpenCL
// runtime's work-group size (a null local size) with the one chosen from the device's properties
// (src/pathtracer/LaunchSize.h): path samples per second and the process's CPU time over wall
// time (getrusage, so every driver thread counts), interleaved rounds and their medians; then the
// mean beauty at max_depth 64 against unbounded.
// "pnanovdb" (issue 17, item 10) compares, on the dense and the wispy cloud and then on the
// default scene (its procedural cloud centred at the origin, its camera and lights), the kernel's density
// lookups through the brick pool (brickgrid.h, the default) and through PNanoVDB
// (NB_GRID_PNANOVDB, nanogrid.h): path samples per second in interleaved rounds and their
// medians, the volume buffers' bytes on the device, and whether the images agree bit for bit
// (same seed; they should, the densities being equal to the bit).
// "bounded" compares, on the dense cloud at the default max_depth (unbounded), the path tracer's
// bounded launches (ranges of work items and a step budget per sample, LaunchSize.h) with one
// launch per pass and no budget: path samples per second in interleaved rounds and their
// medians, and whether the images agree bit for bit.
// "dense": a cumulus-like blob whose core is saturated (density 1), wispy at the edges;
// "wispy": the same blob modulated by high-contrast noise (smoke-like: the maximum far above
// the mean), where one global majorant wastes most collisions.
// Prints one line per mode and the speed-up; both images estimate the same radiance, so their
// mean beauty must agree within noise (printed as a sanity check).
#include "../../kernels/shared/rng.h"
#include "pathtracer/Pathtracer.h"
#include "render/RenderContext.h"
#include "scene/DefaultScene.h"
#include "scene/KernelScene.h"
#include "volume/VolumeData.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

using namespace nimbus;

namespace {

// Value noise with a smooth interpolant, hashed lattice (deterministic, no dependencies).
float lattice(int x, int y, int z)
{
    uint32_t h = uint32_t(x) * 73856093u ^ uint32_t(y) * 19349663u ^ uint32_t(z) * 83492791u;
    h = nbPcgHash(h);
    return float(h >> 8) / 16777216.0f;
}

float valueNoise(float3 p)
{
    int x = int(std::floor(p.x)), y = int(std::floor(p.y)), z = int(std::floor(p.z));
    float fx = p.x - x, fy = p.y - y, fz = p.z - z;
    auto s = [](float t) { return t * t * (3 - 2 * t); };
    float sx = s(fx), sy = s(fy), sz = s(fz);
    float v = 0;
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i)
                v += (i ? sx : 1 - sx) * (j ? sy : 1 - sy) * (k ? sz : 1 - sz) * lattice(x + i, y + j, z + k);
    return v;
}

// A cumulus-like blob: fBm eroding a sphere, zero outside (so many bricks are empty).
bool gWispy = false;

float cloud(float3 u)  // u in [0,1]^3
{
    float3 p = u * 2.0f - splat(1.0f);
    float r = length(p * make_float3(1.0f, 1.4f, 1.0f));
    float n = 0, amp = 0.5f, freq = 4.0f;
    for (int o = 0; o < 5; ++o, amp *= 0.5f, freq *= 2.0f)
        n += amp * valueNoise(p * freq + splat(17.0f * o));
    float d = std::max(0.0f, std::min(1.0f, (0.85f - r) * 3.0f + (n - 0.5f) * 2.5f));
    if (gWispy) {
        float m = valueNoise(p * 9.0f + splat(3.0f));
        d *= m * m * m * m;
    }
    return d;
}

std::shared_ptr<VolumeData> makeCloud(int n)
{
    const int nb = n / 8;
    auto v = std::make_shared<VolumeData>();
    v->name = "cloud";
    v->density.reset({0, 0, 0}, {nb, nb, nb}, 1);
    const int S = BrickGrid::kStored;
    std::vector<float> field(size_t(n + 1) * (n + 1) * (n + 1));
    for (int k = 0; k <= n; ++k)
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i)
                field[(size_t(k) * (n + 1) + j) * (n + 1) + i] =
                    (i < n && j < n && k < n) ? cloud(make_float3((i + 0.5f) / n, (j + 0.5f) / n, (k + 0.5f) / n))
                                              : 0.0f;
    for (int bz = 0; bz < nb; ++bz)
        for (int by = 0; by < nb; ++by)
            for (int bx = 0; bx < nb; ++bx) {
                float* vals = v->density.allocateBrick(bx, by, bz);
                for (int z = 0; z < S; ++z)
                    for (int y = 0; y < S; ++y)
                        for (int x = 0; x < S; ++x)
                            vals[(z * S + y) * S + x] =
                                field[(size_t(bz * 8 + z) * (n + 1) + by * 8 + y) * (n + 1) + bx * 8 + x];
            }
    v->density.pruneZeroBricks();
    const double voxel = 2.0 / n;
    v->worldFromIndex = Transform::translate(-1, -1, -1) * Transform::scale(voxel, voxel, voxel);
    v->indexFromWorld = v->worldFromIndex.inverse();
    v->worldBounds = v->worldFromIndex.box(v->density.activeIndexBounds());
    v->voxelSize = float(voxel);
    v->medium.sigma_s = splat(gWispy ? 60.0f : 12.0f);  // ~20 optical depths across the core
    v->medium.sigma_a = splat(0.05f);
    v->medium.phase = NbPhase{0.8f, 0, 0, 0};
    std::printf("%s cloud: %d^3 voxels, %zu of %d bricks allocated (%.0f%%), %.1f MiB\n", gWispy ? "wispy" : "dense", n,
                v->density.brickCount(), nb * nb * nb, 100.0 * v->density.brickCount() / (nb * nb * nb),
                v->density.memoryBytes() / 1048576.0);
    return v;
}

double cpuSeconds()
{
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : (v[(v.size() - 1) / 2] + v[v.size() / 2]) / 2;
}

// Mean of the channel-averaged beauty and its standard error (from the variance AOV).
std::pair<double, double> meanBeauty(const Film& film)
{
    const Aov* b = film.find("beauty");
    const Aov* v = film.find("variance");
    double mean = 0, var = 0;
    const size_t n = b->pixels.size() / 4;
    for (size_t i = 0; i < n; ++i) {
        mean += (b->pixels[4 * i] + b->pixels[4 * i + 1] + b->pixels[4 * i + 2]) / 3.0 / double(n);
        var += v->pixels[i] / (double(n) * double(n));
    }
    return {mean, std::sqrt(var)};
}

PathtraceOptions benchOptions(const std::string& device, PathtraceStats* stats)
{
    PathtraceOptions pt;
    pt.device = device;
    pt.stats = stats;
    return pt;
}

// The runtime's launch against the chosen one, then the depth cap's bias.
void launchComparison(const RenderContext& ctx, Scene& scene, const std::string& device, int rounds)
{
    std::vector<double> rate[2], busy[2];
    for (int round = 0; round < rounds; ++round)
        for (int mode = 0; mode < 2; ++mode) {
            PathtraceStats stats;
            PathtraceOptions pt = benchOptions(device, &stats);
            pt.runtimeWorkGroupSize = mode == 0;
            Film film;
            const double cpu0 = cpuSeconds();
            const auto t0 = std::chrono::steady_clock::now();
            renderPathtrace(ctx, film, RenderControl{}, pt);
            const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const double cores = (cpuSeconds() - cpu0) / wall;
            rate[mode].push_back(stats.pathsPerSecond());
            busy[mode].push_back(cores);
            std::printf("round %d %-26s %8.0f path samples/s  CPU/wall %.2f  (%zu work-groups of %zu, %.2f s)\n", round,
                        mode ? "chosen from the device:" : "runtime's choice:", stats.pathsPerSecond(), cores,
                        stats.workGroups, stats.localSize, wall);
            if (round == 0 && mode == 0)
                std::printf("device: %s\n", stats.device.c_str());
        }
    std::printf("median of %d rounds: runtime's choice %.0f path samples/s, CPU/wall %.2f; chosen %.0f path samples/s, "
                "CPU/wall %.2f; speed-up %.2fx\n",
                rounds, median(rate[0]), median(busy[0]), median(rate[1]), median(busy[1]),
                median(rate[1]) / std::max(1.0, median(rate[0])));
    double mean[2], se[2];
    for (int mode = 0; mode < 2; ++mode) {
        scene.render.maxDepth = mode == 0 ? 64 : 0;
        Film film;
        renderPathtrace(ctx, film, RenderControl{}, benchOptions(device, nullptr));
        std::tie(mean[mode], se[mode]) = meanBeauty(film);
    }
    std::printf("mean beauty: max_depth 64 %.5f +- %.5f, unbounded %.5f +- %.5f (64 is %+.2f%%)\n", mean[0], se[0],
                mean[1], se[1], 100 * (mean[0] / mean[1] - 1));
}

// Bounded launches (src/pathtracer/LaunchSize.h, the default) against one launch per pass with
// no step budget (the path tracer before them): rounds interleaved after a warm-up, path
// samples per second and their medians, the launches and the longest, and whether the images
// agree bit for bit (they must).
void boundedComparison(const RenderContext& ctx, const std::string& device, int rounds)
{
    std::vector<double> rate[2];
    Film first[2];
    for (int round = -1; round < rounds; ++round)
        for (int mode = 0; mode < 2; ++mode) {
            PathtraceStats stats;
            PathtraceOptions pt = benchOptions(device, &stats);
            if (mode == 0) {
                pt.rangeItems = size_t(1) << 30;
                pt.stepsPerSample = 1 << 30;
            }
            Film film;
            renderPathtrace(ctx, film, RenderControl{}, pt);
            if (round < 0) {  // warm-up: the kernel build, the first touch of the buffers
                first[mode] = film;
                if (mode == 0)
                    std::printf("device: %s\n", stats.device.c_str());
                else
                    std::printf("saved paths' buffer: %zu bytes for %dx%d pixels (%.1f bytes a path)\n",
                                stats.pathStateBytes, film.width, film.height,
                                double(stats.pathStateBytes) / double(film.width * film.height));
                continue;
            }
            rate[mode].push_back(stats.pathsPerSecond());
            std::printf("round %d %-18s %8.0f path samples/s  (%lld launches, longest %.3f s, %lld paths stopped, %.2f s)\n",
                        round, mode ? "bounded launches:" : "one per pass:", stats.pathsPerSecond(), stats.launches,
                        stats.longestLaunchSeconds, stats.stoppedPaths, stats.renderSeconds);
        }
    const Aov* a = first[0].find("beauty");
    const Aov* b = first[1].find("beauty");
    size_t same = 0;
    for (size_t k = 0; k < a->pixels.size(); ++k)
        same += std::memcmp(&a->pixels[k], &b->pixels[k], sizeof(float)) == 0;
    std::printf("median of %d rounds: one launch per pass %.0f path samples/s, bounded %.0f (%.3fx); beauty "
                "bit-identical in %zu of %zu values\n",
                rounds, median(rate[0]), median(rate[1]), median(rate[1]) / std::max(1.0, median(rate[0])), same,
                a->pixels.size());
}

// Brick pool against PNanoVDB density lookups on one cloud: rounds interleaved (pool, nano, pool,
// nano, ...), the first render of each only building or loading its kernel.
void densityComparison(const RenderContext& ctx, const std::string& device, int rounds)
{
    std::vector<double> rate[2], ratio;
    size_t bytes[2] = {0, 0};
    Film first[2];
    for (int round = -1; round < rounds; ++round)
        for (int mode = 0; mode < 2; ++mode) {
            PathtraceStats stats;
            PathtraceOptions pt = benchOptions(device, &stats);
            pt.pnanovdbDensity = mode == 1;
            Film film;
            renderPathtrace(ctx, film, RenderControl{}, pt);
            bytes[mode] = stats.volumeBytes;
            if (round < 0) {  // warm-up: the kernel build, the first touch of the buffers
                first[mode] = film;
                if (mode == 0)
                    std::printf("device: %s\n", stats.device.c_str());
                continue;
            }
            rate[mode].push_back(stats.pathsPerSecond());
            if (mode == 1)
                ratio.push_back(rate[1].back() / std::max(1.0, rate[0].back()));
            std::printf("round %d %-12s %8.0f path samples/s  (%.2f s)\n", round, mode ? "PNanoVDB:" : "brick pool:",
                        stats.pathsPerSecond(), stats.renderSeconds);
        }
    const Aov* a = first[0].find("beauty");
    const Aov* b = first[1].find("beauty");
    size_t same = 0;
    for (size_t k = 0; k < a->pixels.size(); ++k)
        same += std::memcmp(&a->pixels[k], &b->pixels[k], sizeof(float)) == 0;
    std::sort(ratio.begin(), ratio.end());
    std::printf("median of %d rounds: brick pool %.0f, PNanoVDB %.0f path samples/s; PNanoVDB/brick pool: ratio of "
                "medians %.2fx, median of the rounds' ratios %.2fx (range %.2f-%.2f)\n",
                rounds, median(rate[0]), median(rate[1]), median(rate[1]) / std::max(1.0, median(rate[0])),
                median(ratio), ratio.front(), ratio.back());
    std::printf("volume buffers on the device: brick pool %.2f MiB, PNanoVDB %.2f MiB (%.2fx); "
                "beauty bit-identical in %zu of %zu values\n",
                bytes[0] / 1048576.0, bytes[1] / 1048576.0, double(bytes[1]) / double(std::max<size_t>(1, bytes[0])), same,
                a->pixels.size());
}

}  // namespace

int main(int argc, char** argv)
{
    const int spp = argc > 1 ? std::atoi(argv[1]) : 16;
    const int size = argc > 2 ? std::atoi(argv[2]) : 128;
    const std::string device = argc > 3 ? argv[3] : "";
    gWispy = argc > 4 && std::string(argv[4]) == "wispy";
    const bool launch = argc > 4 && std::string(argv[4]) == "launch";
    const bool nano = argc > 4 && std::string(argv[4]) == "pnanovdb";
    const bool bounded = argc > 4 && std::string(argv[4]) == "bounded";
    const int rounds = argc > 5 ? std::max(1, std::atoi(argv[5])) : (nano ? 5 : 3);
    // "pnanovdb" runs both clouds, one after the other; the other modes one.
    for (int cloudPass = 0; cloudPass < (nano ? 3 : 1); ++cloudPass) {
    try {
        if (nano)
            gWispy = cloudPass == 1;
        if (nano && cloudPass == 2) {
            // The default scene's cloud (the procedural generator, ~2 m across, centred at the
            // origin) under its own camera and lights, at the bench's size and samples.
            Scene scene = defaultScene();
            scene.camera.width = scene.camera.height = 128;
            scene.render.method = Method::Pathtrace;
            scene.render.spp = spp;
            scene.render.maxDepth = 64;
            auto ctx = RenderContext::create(scene, /*buildShadowMaps=*/false);
            const VolumeData& v = *ctx->volumes.volumes().at(0);
            std::printf("default scene's cloud: %zu bricks allocated, %.1f MiB\n", v.density.brickCount(),
                        v.density.memoryBytes() / 1048576.0);
            densityComparison(*ctx, device, rounds);
            continue;
        }
        Scene scene;
        scene.camera.width = 128;
        scene.camera.height = 128;
        scene.camera.from = make_float3(0.4f, 0.3f, 3.6f);
        scene.camera.to = make_float3(0, 0, 0);
        scene.camera.fov = 40;
        scene.render.method = Method::Pathtrace;
        scene.render.spp = spp;
        scene.render.maxDepth = launch || bounded ? 0 : 64;
        Light sun;
        sun.name = "sun";
        sun.type = LightType::Distant;
        sun.direction = normalize(make_float3(0.4f, -1, -0.3f));
        sun.irradiance = splat(3.0f);
        scene.lights.push_back(sun);
        Light sky;
        sky.name = "sky";
        sky.type = LightType::Environment;
        sky.radiance = make_float3(0.2f, 0.3f, 0.5f);
        scene.lights.push_back(sky);

        RenderContext ctx;
        ctx.scene = &scene;
        ctx.volumes = VolumeSet({makeCloud(size)}, scene.render.step);
        for (size_t i = 0; i < scene.lights.size(); ++i) {
            LightEntry e;
            e.light = makeNbLight(scene.lights[i], int(i));
            e.aov = "light_" + scene.lights[i].name;
            ctx.lights.push_back(std::move(e));
        }
        ctx.background = sky.radiance;
        if (launch) {
            launchComparison(ctx, scene, device, rounds);
            return 0;
        }
        if (bounded) {
            boundedComparison(ctx, device, rounds);
            return 0;
        }
        if (nano) {
            densityComparison(ctx, device, rounds);
            continue;
        }

        double rate[2] = {0, 0};
        for (int mode = 0; mode < 2; ++mode) {
            PathtraceStats stats;
            PathtraceOptions pt = benchOptions(device, &stats);
            pt.globalMajorant = mode == 1;
            Film film;
            renderPathtrace(ctx, film, RenderControl{}, pt);
            const double mean = meanBeauty(film).first;
            rate[mode] = stats.pathsPerSecond();
            std::printf("%-16s %8.0f path samples/s  (%lld spp, %dx%d, %.2f s, build %.2f s%s)  mean beauty %.5f\n",
                        mode ? "global majorant" : "majorant grid", rate[mode], stats.samplesPerPixel, film.width,
                        film.height, stats.renderSeconds, stats.buildSeconds, stats.kernelFromCache ? " cached" : "",
                        mean);
            if (mode == 0)
                std::printf("device: %s\n", stats.device.c_str());
        }
        std::printf("speed-up of the majorant grid: %.2fx\n", rate[1] > 0 ? rate[0] / rate[1] : 0.0);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_pathtrace: %s\n", e.what());
        return 1;
    }
    }
    return 0;
}
