// bench_sky: what a sky costs (issue 17, item 1): the default scene (`nimbus render --default`)
// lit by its sun alone (its distant light; the default's own sky removed) against the same with an
// environment light added,
// uniform and as an HDR lat-long map, in `single` and `wkb`. Target: sun + sky <= 1.5x the sun
// alone. The sky is read from its grid (src/render/SkyLight.h), built once per render.
//
// The renders run in this process through the public API, interleaved (sun, sky, sky map, sun,
// ...) so that a shared machine's load falls on all alike; best of `repeats` (default 3). Times
// are process CPU seconds (getrusage: all threads) and the sky-grid and march stages (wall).
// Output: Markdown on stdout; with a path, also into that file between <!-- bench:sky -->
// markers (docs/benchmarks.md).
//
// Usage: bench_sky [docs/benchmarks.md] [--quick]
#include "BenchReport.h"

#include "engine/Renderer.h"
#include "scene/DefaultScene.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

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
    double total = 1e30, sky = 1e30, march = 1e30;
};

void timeOnce(const Scene& s, Timing& t)
{
    const double c0 = cpuSeconds();
    RenderResult res = render(s);
    t.total = std::min(t.total, cpuSeconds() - c0);
    t.sky = std::min(t.sky, res.stats.stage("sky grid"));
    t.march = std::min(t.march, res.stats.stage("march"));
}

// A daylight sky, 512 x 256: blue above, brighter toward one horizon, a dark ground.
std::string writeSkyMap(const std::string& path)
{
    const int W = 512, H = 256;
    std::vector<float> rgb(size_t(W * H) * 3);
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            const double v = (j + 0.5) / H, u = (i + 0.5) / W, up = std::cos(M_PI * v);
            const double side = 0.5 + 0.5 * std::cos(2 * M_PI * (u - 0.3)) * std::sin(M_PI * v);
            float* t = rgb.data() + 3 * (j * W + i);
            if (up > 0)
                t[0] = float(0.15 + 0.25 * side * (1 - up)), t[1] = float(0.25 + 0.2 * side * (1 - up)), t[2] = 0.45f;
            else
                t[0] = t[1] = t[2] = 0.03f;
        }
    auto out = OIIO::ImageOutput::create(path);
    OIIO::ImageSpec spec(W, H, 3, OIIO::TypeDesc::FLOAT);
    out->open(path, spec);
    out->write_image(OIIO::TypeDesc::FLOAT, rgb.data());
    out->close();
    return path;
}

}  // namespace

int main(int argc, char** argv)
{
    std::string docs;
    bool quick = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--quick")
            quick = true;
        else
            docs = a;
    }
    const int repeats = quick ? 1 : 3;
    const std::string dir = std::filesystem::temp_directory_path() / ("nimbus-bench-sky-" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    const std::string map = writeSkyMap(dir + "/sky.exr");

    std::ostringstream md;
    Scene base = defaultScene();  // its sun alone: the default's environment light removed
    base.lights.erase(std::remove_if(base.lights.begin(), base.lights.end(),
                                     [](const Light& l) { return l.type == LightType::Environment; }),
                      base.lights.end());
    base.output.file = dir + "/unused.exr";
    base.output.preview.clear();
    md << "The default scene (`nimbus render --default`: " << base.camera.width << "x" << base.camera.height
       << ", the procedural cloud, its sun alone) against the same with an environment light: uniform "
          "(radiance 0.3 0.4 0.6), and a 512x256 lat-long sky map. CPU seconds (all threads), best of "
       << repeats << ", interleaved; ratio = with sky / sun alone (target <= 1.5). Sky grid and march: wall seconds.\n\n";
    md << "| method | sun (s) | sun + uniform sky (s) | ratio | sun + sky map (s) | ratio | sky grid (s) | march sun / sky "
          "map (s) |\n";
    md << "|---|---|---|---|---|---|---|---|\n";
    for (Method m : {Method::Single, Method::Wkb}) {
        Scene sun = base;
        sun.render.method = m;
        Scene uniform = sun;
        Light sky;
        sky.name = "sky";
        sky.type = LightType::Environment;
        sky.radiance = make_float3(0.3f, 0.4f, 0.6f);
        uniform.lights.push_back(sky);
        Scene mapped = sun;
        sky.radiance = splat(1.0f);
        sky.map = map;
        mapped.lights.push_back(sky);
        Timing a, b, c;
        for (int r = 0; r < repeats; ++r) {
            timeOnce(sun, a);
            timeOnce(uniform, b);
            timeOnce(mapped, c);
        }
        char row[400];
        std::snprintf(row, sizeof row, "| %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f / %.2f |\n",
                      methodName(m), a.total, b.total, b.total / a.total, c.total, c.total / a.total, c.sky, a.march,
                      c.march);
        md << row;
        std::fprintf(stderr, "%s", row);
    }
    std::printf("%s", md.str().c_str());
    if (!docs.empty())
        bench::replaceSection(docs, "sky", md.str());
    std::filesystem::remove_all(dir);
    return 0;
}
