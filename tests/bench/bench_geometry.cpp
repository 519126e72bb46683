// bench_geometry: what scene geometry costs (issue 14): `single` and `wkb` render time of a cloud
// with and without a 100k-triangle mesh (a tessellated torus, written to a temporary OBJ and read
// back through Assimp like any scene's mesh) that both holds out part of the frame and shadows the
// cloud. Target: with / without <= 1.3 for both methods.
//
// Then the path tracer (issue 14, item 3): path samples per second on the same cloud without the
// torus, with it as holdout and shadow caster, and with it as a shadow caster only (so that no
// pixel is made cheap by being held out), in interleaved rounds (without, with, caster only, ...)
// and their medians, the same seed and samples for all. Rates count the kernel launches only
// (PathtraceStats::renderSeconds: not the kernel build, not the BVH build, reported beside).
//
// Each render runs in this process through the public API, best of `repeats` (default 3). Times
// are process CPU seconds (getrusage: all threads), which other jobs on a shared machine disturb
// less than wall time; the geometry stage (mesh read, BVH build) is reported beside. The holdout
// also shortens the camera rays it cuts, so the march alone can get cheaper: the table says how
// much of the frame the torus covers. Output: Markdown on stdout; with a path, also into that file
// between <!-- bench:geometry --> markers (docs/benchmarks.md).
//
// Usage: bench_geometry [docs/benchmarks.md] [--quick]
#include "../geometry/TorusMesh.h"
#include "BenchReport.h"

#include "engine/Renderer.h"
#include "../../kernels/shared/light.h"
#include "../../kernels/shared/rng.h"
#include "geometry/KernelBvh.h"
#include "pathtracer/Pathtracer.h"
#include "render/RenderContext.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>

#include <sys/resource.h>
#include <unistd.h>

using namespace nimbus;

namespace {

double cpuSeconds()
{
    rusage u;
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Timing {
    double total = 1e30, geometry = 0, march = 1e30;
    RenderResult last;
};

Timing time(const Scene& s, int repeats)
{
    Timing t;
    for (int r = 0; r < repeats; ++r) {
        const double c0 = cpuSeconds();
        RenderResult res = render(s);
        t.total = std::min(t.total, cpuSeconds() - c0);
        t.march = std::min(t.march, res.stats.stage("march"));
        t.geometry = res.stats.stage("geometry");
        t.last = std::move(res);
    }
    return t;
}

Scene cloudScene(int width, int height, Method m)
{
    Scene s;
    s.camera.from = make_float3(0.0f, 0.5f, 5.5f);
    s.camera.to = make_float3(0.0f, 0.1f, 0.0f);
    s.camera.fov = 40.0f;
    s.camera.width = width;
    s.camera.height = height;
    s.render.spp = 2;
    s.render.method = m;
    s.output.file = "unused.exr";
    Volume v;
    v.name = "cloud";
    v.source.type = SourceType::Procedural;
    v.source.generator = "cloud";
    v.source.params = {{"radius", 1.0}, {"voxel_size", 0.02}};
    v.medium.sigma_s = splat(8.0f);
    v.medium.sigma_a = splat(0.08f);
    v.medium.phase = NbPhase{0.8f, 0, 0, 0};
    s.volumes.push_back(v);
    Light key;
    key.name = "key";
    key.type = LightType::Distant;
    key.direction = normalize(make_float3(1.0f, -1.0f, -0.7f));
    key.irradiance = splat(3.0f);
    s.lights.push_back(key);
    return s;
}

// Of the pixels that see the cloud without the torus, the share it holds out entirely.
double heldOutFraction(const Film& without, const Film& with)
{
    const Aov* a = without.find("alpha");
    const Aov* b = with.find("alpha");
    size_t cloud = 0, held = 0;
    for (size_t i = 0; i < a->pixels.size(); ++i)
        if (a->pixels[i] > 0.0f) {
            ++cloud;
            held += b->pixels[i] == 0.0f;
        }
    return cloud ? double(held) / double(cloud) : 0.0;
}

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
}

// Closest-hit and any-hit queries per second of the kernel's traversal (host build, one thread).
std::string traversalRate(const GeometrySet& set)
{
    const KernelBvh bvh = buildKernelBvh(set);
    const Bbox b = set.objects()[0].bounds;
    const float3 c = (b.lo + b.hi) * 0.5f, e = b.hi - b.lo;
    const float radius = 1.5f * length(e);
    constexpr int n = 200000;
    std::vector<float3> o(n), d(n);
    NbRng rng = nbRngStart(3, 0, 0);
    for (int i = 0; i < n; ++i) {
        o[size_t(i)] = c + nbSampleSphereUniform(nbRngNext(&rng), nbRngNext(&rng)) * radius;
        const float3 target = c + make_float3(e.x * (nbRngNext(&rng) - 0.5f), e.y * (nbRngNext(&rng) - 0.5f),
                                              e.z * (nbRngNext(&rng) - 0.5f));
        d[size_t(i)] = normalize(target - o[size_t(i)]);
    }
    double rate[2];
    int hits = 0;
    for (int anyHit = 0; anyHit < 2; ++anyHit) {
        const auto t0 = std::chrono::steady_clock::now();
        for (int i = 0; i < n; ++i)
            hits += nbGeomTrace(bvh.nodes.data(), bvh.prims.data(), bvh.scene, o[size_t(i)], d[size_t(i)], 0.0f,
                                INFINITY, anyHit ? NB_GEOM_SHADOWS : NB_GEOM_HOLDOUT, anyHit) < INFINITY;
        rate[anyHit] = n / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    char line[320];
    std::snprintf(line, sizeof line,
                  "Traversal alone (kernels/shared/geometry.h built for the host, one thread, %d random rays at the "
                  "torus, %.0f%% hit): %.2f M closest-hit and %.2f M any-hit queries/s; %zu nodes, depth %d.\n",
                  n, 50.0 * hits / n, rate[0] * 1e-6, rate[1] * 1e-6, bvh.nodes.size(), bvh.depth);
    return line;
}

// Path samples per second of the three variants, interleaved over `rounds`.
std::string pathtraceTable(const Scene& plain, const Geometry& ring, int rounds, int spp)
{
    Scene both = plain, caster = plain;
    both.geometry.push_back(ring);
    Geometry shadowOnly = ring;
    shadowOnly.holdout = false;
    caster.geometry.push_back(shadowOnly);
    const Scene* scenes[3] = {&plain, &both, &caster};
    const char* names[3] = {"without the torus", "torus: holdout and shadow caster", "torus: shadow caster only"};
    std::vector<Scene> ps;  // the contexts point at their scenes
    for (const Scene* s : scenes) {
        ps.push_back(*s);
        ps.back().render.method = Method::Pathtrace;
        ps.back().render.spp = spp;
    }
    std::vector<std::unique_ptr<RenderContext>> ctx;
    for (const Scene& s : ps)
        ctx.push_back(RenderContext::create(s, false));
    std::vector<double> rate[3];
    PathtraceStats last[3];
    std::string device;
    Film films[3];
    for (int round = -1; round < rounds; ++round)  // round -1: kernel builds (cached after)
        for (int v = 0; v < 3; ++v) {
            PathtraceStats stats;
            PathtraceOptions pt;
            pt.stats = &stats;
            Film film;
            renderPathtrace(*ctx[size_t(v)], film, RenderControl{}, pt);
            if (round < 0)
                continue;
            rate[v].push_back(stats.pathsPerSecond());
            last[v] = stats;
            films[v] = std::move(film);
            std::fprintf(stderr, "round %d %-34s %9.0f path samples/s\n", round, names[v], stats.pathsPerSecond());
        }
    std::ostringstream md;
    md << "Path tracer: the same cloud at " << plain.camera.width << "x" << plain.camera.height << ", " << spp
       << " spp per render, unbounded depth, device " << last[0].device << "; medians of " << rounds
       << " interleaved rounds. BVH: " << last[1].geometryBytes / 1024 << " KiB of nodes and primitives, built in "
       << std::fixed;
    md.precision(3);
    md << last[1].geometryBuildSeconds << " s (Embree's builder and flattening).\n\n"
       << "A caster ends the paths that reach it (absorbed) and a holdout ends camera paths before the cloud "
       << "behind it, so paths get shorter and path samples per second can rise; the traversal's own cost "
       << "is the queries-per-second line below the table.\n\n"
       << "| path tracer | path samples/s | relative to without | cloud pixels held out |\n|---|---|---|---|\n";
    for (int v = 0; v < 3; ++v) {
        char row[256];
        std::snprintf(row, sizeof row, "| %s | %.0f | %.2f | %.0f%% |\n", names[v], median(rate[v]),
                      median(rate[v]) / std::max(1.0, median(rate[0])),
                      v == 1 ? 100.0 * heldOutFraction(films[0], films[1]) : 0.0);
        md << row;
    }
    md << "\n" << traversalRate(ctx[1]->geometry->geometry());
    return md.str();
}

}  // namespace

int main(int argc, char** argv)
{
    std::string out;
    bool quick = false;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--quick")
            quick = true;
        else
            out = a;
    }
    const int repeats = quick ? 1 : 3;
    const int w = quick ? 160 : 480, h = quick ? 90 : 270;

    // 2 x 500 x 100 = 100000 triangles: a ring of radius 1.1 m, tube 0.12 m, tilted through the
    // cloud's front half (holding it out there) and above it (shadowing it).
    const auto dir = std::filesystem::temp_directory_path() / ("nimbus-bench-geometry-" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    const std::string obj = (dir / "torus.obj").string();
    const TriangleMesh torus = test::torusMesh(1.1f, 0.12f, 500, 100);
    test::writeObj(torus, obj);
    Geometry ring;
    ring.name = "torus";
    ring.file = obj;
    ring.transform = Transform::translate(0, 0.3, 0.6) * Transform::rotateDegrees(35, 1, 0, 0.2);

    std::ostringstream md;
    md << "Cloud (procedural, voxel 0.02 m) at " << w << "x" << h << ", 2 spp, one distant light, with and without "
       << "a " << torus.triangleCount() << "-triangle torus (OBJ through Assimp; holdout and shadow caster). "
       << "CPU seconds (all threads), best of " << repeats << ". Ratio = with / without (target <= 1.3).\n\n"
       << "| method | without (s) | with (s) | ratio | march without / with (s) | geometry stage (wall s) | "
          "cloud pixels held out |\n|---|---|---|---|---|---|---|\n";
    for (Method m : {Method::Single, Method::Wkb}) {
        Scene plain = cloudScene(w, h, m);
        Scene with = plain;
        with.geometry.push_back(ring);
        const Timing a = time(plain, repeats), b = time(with, repeats);
        char row[256];
        std::snprintf(row, sizeof row, "| %s | %.2f | %.2f | %.2f | %.2f / %.2f | %.3f | %.0f%% |\n", methodName(m),
                      a.total, b.total, b.total / a.total, a.march, b.march, b.geometry,
                      100.0 * heldOutFraction(a.last.film, b.last.film));
        md << row;
        if (m == Method::Single)
            md.flush();
    }
    // The path tracer at a smaller frame: its paths are long in this albedo-0.99 cloud.
    md << "\n" << pathtraceTable(cloudScene(quick ? 80 : 160, quick ? 45 : 90, Method::Pathtrace), ring,
                                 quick ? 1 : 3, quick ? 2 : 64);
    std::filesystem::remove_all(dir);
    std::printf("%s", md.str().c_str());
    if (!out.empty())
        bench::replaceSection(out, "geometry", md.str());
    return 0;
}
