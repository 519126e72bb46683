// bench_wkb: the cost of WKB multiple scattering (issue 3): `wkb` render time over `single` render
// time at the same image settings, on procedural clouds of increasing optical thickness, and the
// light pyramids' memory against the density grid's. Targets: wkb/single <= 2.5 (Tessendorf:
// "roughly doubling your resources will get you the complete global illumination solution") and
// pyramids <= density.
//
// Each render runs in this process through the public API (render(Scene)), best of `repeats`
// (default 3). Times are process CPU seconds (getrusage: all threads), which other jobs on a
// shared machine disturb far less than wall time; the march stage's wall time is reported beside.
// Both methods build the same volumes and shadow maps, so the ratio of whole renders is what a
// user pays, and the ratio of the march stages the per-ray cost. A second table times the
// variants (source placement, kernel) on one cloud. Output: Markdown on stdout; with a path, also
// into that file between <!-- bench:wkb --> markers (docs/benchmarks.md).
//
// Usage: bench_wkb [docs/benchmarks.md] [--quick]
#include "BenchReport.h"

#include "engine/Renderer.h"

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <sys/resource.h>

using namespace nimbus;

namespace {

struct Timing {
    double total = 1e30, march = 1e30;
    RenderResult last;
};

double meanOf(const Film& f, const char* aov)
{
    const Aov* a = f.find(aov);
    if (!a || a->pixels.empty())
        return 0.0;
    double s = 0;
    for (float v : a->pixels)
        s += v;
    return s / double(a->pixels.size());
}

double cpuSeconds()
{
    rusage u;
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

Timing time(Scene s, Method m, int repeats)
{
    s.render.method = m;
    Timing t;
    for (int r = 0; r < repeats; ++r) {
        const double c0 = cpuSeconds();
        RenderResult res = render(s);
        t.total = std::min(t.total, cpuSeconds() - c0);
        t.march = std::min(t.march, res.stats.stage("march"));
        t.last = std::move(res);
    }
    return t;
}

Scene cloudScene(float sigma_s, int width, int height, float voxelFraction)
{
    Scene s;
    s.camera.from = make_float3(0.0f, 0.5f, 5.5f);
    s.camera.to = make_float3(0.0f, 0.1f, 0.0f);
    s.camera.fov = 40.0f;
    s.camera.width = width;
    s.camera.height = height;
    s.render.spp = 2;
    s.output.file = "unused.exr";
    Volume v;
    v.name = "cloud";
    v.source.type = SourceType::Procedural;
    v.source.generator = "cloud";
    v.source.params = {{"radius", 1.0}, {"voxel_size", voxelFraction}};
    v.medium.sigma_s = splat(sigma_s);
    v.medium.sigma_a = splat(0.01f * sigma_s);
    v.medium.phase = NbPhase{0.8f, 0, 0, 0};
    s.volumes.push_back(v);
    Light key;
    key.name = "key";
    key.type = LightType::Distant;
    key.direction = normalize(make_float3(1.0f, -1.0f, -0.7f));
    key.irradiance = splat(3.0f);
    s.lights.push_back(key);
    Light fill;
    fill.name = "fill";
    fill.type = LightType::Distant;
    fill.direction = normalize(make_float3(-1.0f, -0.3f, -0.5f));
    fill.irradiance = make_float3(0.1f, 0.15f, 0.2f);
    s.lights.push_back(fill);
    return s;
}

std::string mib(size_t b)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", double(b) / (1 << 20));
    return buf;
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
    const int W = quick ? 96 : 240, H = quick ? 72 : 180;
    const float voxel = quick ? 1.0f / 24 : 1.0f / 48;
    struct Cloud {
        const char* name;
        float sigma_s;
    };
    const Cloud clouds[] = {{"wisp", 0.5f}, {"cumulus", 4.0f}, {"dense", 20.0f}, {"opaque", 100.0f}};

    std::ostringstream md;
    md << "Procedural cloud (radius 1 m, voxel " << voxel << " m), HG g = 0.8, albedo 0.99, two distant lights, " << W
       << "x" << H << " pixels, " << 2 << " spp, best of " << repeats
       << ". \"single\" and \"wkb\" are CPU seconds of whole "
       << "renders (volumes, shadow maps, light volumes, pyramids, march); \"march\" is the camera-ray stage alone, "
       << "wall seconds.\n\n";
    md << "| cloud | sigma_s (1/m) | optical depth across (bound) | single CPU s | wkb CPU s | wkb/single | march "
          "single s | "
          "march wkb s | march ratio | pyramids MiB | density MiB | pyramids/density | mean L2+/L1 |\n";
    md << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Cloud& c : clouds) {
        Scene s = cloudScene(c.sigma_s, W, H, voxel);
        Timing single = time(s, Method::Single, repeats);
        Timing wkb = time(s, Method::Wkb, repeats);
        const RenderPlan& p = wkb.last.plan;
        char row[512];
        std::snprintf(row, sizeof row,
                      "| %s | %.3g | %.3g | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %s | %s | %.2f | %.2f |\n",
                      c.name, c.sigma_s, p.volumes.empty() ? 0.0 : p.volumes[0].opticalDepthAcross, single.total,
                      wkb.total, wkb.total / single.total, single.march, wkb.march, wkb.march / single.march,
                      mib(wkb.last.stats.pyramidBytes).c_str(), mib(p.wkb.densityBytes).c_str(),
                      double(wkb.last.stats.pyramidBytes) / double(std::max<size_t>(p.wkb.densityBytes, 1)),
                      meanOf(wkb.last.film, "L2plus") / std::max(1e-30, meanOf(wkb.last.film, "L1")));
        md << row;
        std::fprintf(stderr, "%s", row);
    }

    md << "\nVariants on the \"dense\" cloud (same settings, order 2 traced in each; docs/wkb.md):\n\n";
    md << "| source | kernel | order 2 | wkb CPU s | march s | mean L2+ |\n|---|---|---|---|---|---|\n";
    struct Variant {
        WkbSource source;
        WkbKernel kernel;
        WkbOrder2 order2;
        const char *sname, *kname;
    };
    const Variant variants[] = {
        {WkbSource::Straight, WkbKernel::Gaussian, WkbOrder2::Traced, "straight", "gaussian"},
        {WkbSource::RandomWalk, WkbKernel::Gaussian, WkbOrder2::Traced, "random_walk", "gaussian"},
        {WkbSource::Straight, WkbKernel::Exact, WkbOrder2::Traced, "straight", "exact"},
        {WkbSource::RandomWalk, WkbKernel::Exact, WkbOrder2::Traced, "random_walk", "exact"},
        {WkbSource::RandomWalk, WkbKernel::Exact, WkbOrder2::Kernel, "random_walk", "exact"}};
    for (const Variant& v : variants) {
        Scene s = cloudScene(20.0f, W, H, voxel);
        s.render.wkbSource = v.source;
        s.render.wkbKernel = v.kernel;
        s.render.wkbOrder2 = v.order2;
        Timing t = time(s, Method::Wkb, repeats);
        char row[256];
        std::snprintf(row, sizeof row, "| %s | %s | %s | %.2f | %.2f | %.4g |\n", v.sname, v.kname,
                      wkbOrder2Name(v.order2), t.total, t.march, meanOf(t.last.film, "L2plus"));
        md << row;
        std::fprintf(stderr, "%s", row);
    }
    std::printf("%s", md.str().c_str());
    if (!out.empty())
        nimbus::bench::replaceSection(out, "wkb", md.str());
    return 0;
}
