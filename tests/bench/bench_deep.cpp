// bench_deep: what deep output costs (issue 14, item 5; docs/output.md "Deep output"): `single` and
// `wkb` render time of a cloud without deep output and with output.deep at deep_samples 8 and 32,
// and the deep image's size (samples per pixel, bytes in memory). Each slice edge marches every
// camera sample again up to that edge, so the march's cost grows by about deep_samples / 2 (the
// shadow maps and wkb's light volumes are built once); the table says what it is.
//
// Each render runs in this process through the public API, best of `repeats` (default 2). Times are
// process CPU seconds (getrusage: all threads); the march stage (wall) is reported beside. Output:
// Markdown on stdout; with a path, also into that file between <!-- bench:deep --> markers
// (docs/benchmarks.md).
//
// Usage: bench_deep [docs/benchmarks.md] [--quick]
#include "BenchReport.h"

#include "engine/Renderer.h"

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <string>

#include <sys/resource.h>

using namespace nimbus;

namespace {

double cpuSeconds()
{
    rusage u;
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Timing {
    double total = 1e30, march = 1e30;
    double meanSamples = 0, maxSamples = 0;
    size_t deepBytes = 0;
};

Timing time(const Scene& s, int repeats)
{
    Timing t;
    for (int r = 0; r < repeats; ++r) {
        const double c0 = cpuSeconds();
        RenderResult res = render(s);
        t.total = std::min(t.total, cpuSeconds() - c0);
        t.march = std::min(t.march, res.stats.stage("march"));
        if (res.film.deep) {
            size_t samples = 0, most = 0, pixels = 0;
            for (const auto& p : res.film.deep->pixels) {
                samples += p.size(), most = std::max(most, p.size());
                pixels += !p.empty();
            }
            t.meanSamples = pixels ? double(samples) / double(pixels) : 0.0;
            t.maxSamples = double(most);
            t.deepBytes = samples * sizeof(DeepSample);
        }
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
    v.source.params = {{"radius", 1.0}, {"voxel_size", 0.03}};
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

}  // namespace

int main(int argc, char** argv)
{
    std::string report;
    bool quick = false;
    for (int i = 1; i < argc; ++i)
        (std::string(argv[i]) == "--quick" ? quick = true : (report = argv[i], false));
    const int width = quick ? 160 : 320, height = quick ? 90 : 180, repeats = quick ? 1 : 2;
    std::ostringstream md;
    md << "Cloud (procedural, voxel 0.03 m) at " << width << "x" << height
       << ", 2 spp, one distant light. CPU seconds (all threads), best of " << repeats
       << "; ratio = with deep output / without. Samples: per pixel that has any.\n\n"
       << "| method | deep_samples | total (s) | ratio | march (wall s) | march ratio | samples mean / max | deep "
          "pixels in memory |\n|---|---|---|---|---|---|---|---|\n";
    for (Method m : {Method::Single, Method::Wkb}) {
        Scene plain = cloudScene(width, height, m);
        const Timing base = time(plain, repeats);
        char line[400];
        std::snprintf(line, sizeof line, "| %s | none | %.2f | 1.00 | %.2f | 1.00 | - | - |\n", methodName(m),
                      base.total, base.march);
        md << line;
        std::fputs(line, stderr);
        for (int n : {8, 32}) {
            Scene deep = plain;
            deep.output.deep = "unused_deep.exr";
            deep.output.deepSamples = n;
            const Timing t = time(deep, repeats);
            std::snprintf(line, sizeof line, "| %s | %d | %.2f | %.2f | %.2f | %.1f | %.1f / %.0f | %.1f MiB |\n",
                          methodName(m), n, t.total, t.total / base.total, t.march, t.march / base.march,
                          t.meanSamples, t.maxSamples, double(t.deepBytes) / (1 << 20));
            md << line;
            std::fputs(line, stderr);
        }
    }
    std::fputs(md.str().c_str(), stdout);
    if (!report.empty())
        bench::replaceSection(report, "deep", md.str());
    return 0;
}
