// bench_geometry: what scene geometry costs (issue 14): `single` and `wkb` render time of a cloud
// with and without a 100k-triangle mesh (a tessellated torus, written to a temporary OBJ and read
// back through Assimp like any scene's mesh) that both holds out part of the frame and shadows the
// cloud. Target: with / without <= 1.3 for both methods.
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

#include <algorithm>
#include <cstdio>
#include <filesystem>
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
    std::filesystem::remove_all(dir);
    std::printf("%s", md.str().c_str());
    if (!out.empty())
        bench::replaceSection(out, "geometry", md.str());
    return 0;
}
