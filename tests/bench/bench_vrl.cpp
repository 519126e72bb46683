// bench_vrl: virtual ray lights against the path tracer at equal time (issue 15).
//
//   bench_vrl equal-time [docs/benchmarks.md] [--quick] [--seeds N] [--only SCENE] [--reference-seconds S]
//       Thin-to-medium media lit by point and spot lights, and a thick cloud under a sun (where
//       the path tracer is expected to win): beauty and L2plus relMSE (nimbus compare's metric,
//       src/compare/ErrorMetrics.cpp) against a long path-traced reference, for `pathtrace` and
//       `vrl` at the same time limit, averaged over N seeds (default 2); then vrl_paths in {1, 4, 16, 64} on two of
//       the scenes (the default's justification). Into <!-- bench:vrl --> of docs/benchmarks.md.
//       --only SCENE: that scene alone (no vrl_paths table); --reference-seconds S: the reference's
//       time (default 40). Each seed's beauty relMSE is printed to stderr (the errors of these
//       scenes are heavy-tailed: one seed can hold most of a mean).
//   bench_vrl oppitz [docs/validation.md] [--quick]
//       Oppitz 2018 ch. 9 in kind: a point light in a large homogeneous medium, g in
//       {-0.9, 0, 0.9}, `vrl` with 1 and 10 light paths per iteration, with the advanced and the
//       simple joint distribution, and `pathtrace`: relMSE against a converged reference at a
//       ladder of equal times, a table and an error-against-time chart (text, log-log). Into
//       <!-- bench:vrl-oppitz --> of docs/validation.md.
//
// Both methods run through the public API in this process, on all cores (the path tracer on the
// OpenCL device the ICD loader offers, PoCL on CI; vrl with TBB). The time is each render's
// time_limit (the loop's own clock, after the scene is built); the error subtracts nothing: the
// reference's own noise floor is printed beside it.
#include "BenchReport.h"

#include "compare/Compare.h"
#include "engine/Renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace nimbus;

namespace {

bool gQuick = false;
std::string gOnly;             // --only SCENE
double gReferenceSeconds = 0;  // --reference-seconds S (0: 40, or 6 with --quick)
int gSeeds = 0;  // --seeds N: seeds per render in equal-time (0: 2, or 1 with --quick)

Scene baseScene(float3 from, float3 to, int size)
{
    Scene s;
    s.camera.width = size;
    s.camera.height = size;
    s.camera.from = from;
    s.camera.to = to;
    s.camera.fov = 45;
    s.output.file = "unused.exr";
    return s;
}

Volume box(float size, float sigmaS, float sigmaA, float g, double voxel)
{
    Volume v;
    v.name = "medium";
    v.source.type = SourceType::Procedural;
    v.source.generator = "box";
    v.source.params = {{"size", size}, {"voxel_size", voxel}};
    v.medium.sigma_s = splat(sigmaS);
    v.medium.sigma_a = splat(sigmaA);
    v.medium.phase = NbPhase{g, 0, 0, 0};
    return v;
}

Volume sphere(float radius, float sigmaS, float sigmaA, float g)
{
    Volume v;
    v.name = "medium";
    v.source.type = SourceType::Procedural;
    v.source.generator = "sphere";
    v.source.params = {{"radius", radius}, {"voxel_size", 0.05}, {"falloff", 0.05}};
    v.medium.sigma_s = splat(sigmaS);
    v.medium.sigma_a = splat(sigmaA);
    v.medium.phase = NbPhase{g, 0, 0, 0};
    return v;
}

Light point(float3 p, float intensity)
{
    Light l;
    l.name = "lamp";
    l.type = LightType::Point;
    l.position = p;
    l.intensity = splat(intensity);
    return l;
}

struct Named {
    std::string name, what;
    Scene scene;
};

std::vector<Named> equalTimeScenes()
{
    std::vector<Named> out;
    const int n = 48;
    {
        Scene s = baseScene(make_float3(0, 0.4f, 3.2f), make_float3(0, 0, 0), n);
        s.volumes.push_back(box(4.0f, 0.3f, 0.03f, 0.3f, 0.125));
        s.lights.push_back(point(make_float3(0.3f, 0.2f, -0.5f), 4.0f));
        out.push_back({"haze_lamp", "4 m haze box, tau 0.66 per m, g 0.3, a point light inside", s});
    }
    {
        Scene s = baseScene(make_float3(0, 0, 3.5f), make_float3(0, 0, 0), n);
        s.volumes.push_back(box(3.0f, 0.4f, 0.05f, 0.4f, 0.125));
        Light l;
        l.name = "spot";
        l.type = LightType::Spot;
        l.position = make_float3(-1.2f, 1.9f, 0);
        l.direction = normalize(make_float3(0.5f, -1, 0));
        l.intensity = splat(10.0f);
        l.coneAngle = 25;
        l.coneSoftness = 4;
        s.lights.push_back(l);
        out.push_back({"spot_beam", "spot beam through a 3 m haze box, sigma_t 0.45 per m, g 0.4", s});
    }
    {
        Scene s = baseScene(make_float3(0, 0.3f, 3.5f), make_float3(0, 0, 0), n);
        s.volumes.push_back(sphere(1.0f, 1.9f, 0.1f, 0.5f));
        s.lights.push_back(point(make_float3(1.5f, 1.0f, 0.4f), 4.0f));
        out.push_back(
            {"medium_sphere", "sphere of radius 1 m, sigma_t 2 per m, albedo 0.95, g 0.5, point light outside", s});
    }
    {
        Scene s = baseScene(make_float3(0, 0.3f, 3.2f), make_float3(0, 0, 0), n);
        s.volumes.push_back(box(4.0f, 0.25f, 0.02f, 0.9f, 0.125));
        s.lights.push_back(point(make_float3(0.2f, 0.1f, -1.2f), 4.0f));
        out.push_back({"forward_haze",
                       "4 m haze box, sigma_t 0.27 per m, g 0.9, a point light inside behind the view's centre", s});
    }
    {
        Scene s = baseScene(make_float3(0.4f, 0.3f, 3.5f), make_float3(0, 0, 0), n);
        Volume v;
        v.name = "cloud";
        v.source.type = SourceType::Procedural;
        v.source.generator = "cloud";
        v.source.params = {{"radius", 1.0}, {"voxel_size", 0.04}, {"seed", 3}};
        v.medium.sigma_s = splat(20.0f);
        v.medium.sigma_a = splat(0.1f);
        v.medium.phase = NbPhase{0.6f, 0, 0, 0};
        s.volumes.push_back(v);
        Light sun;
        sun.name = "sun";
        sun.type = LightType::Distant;
        sun.direction = normalize(make_float3(0.3f, -1, -0.4f));
        sun.irradiance = splat(3.0f);
        s.lights.push_back(sun);
        out.push_back({"thick_cloud_sun", "procedural cloud, sigma_t up to 20 per m, g 0.6, under a sun", s});
    }
    return out;
}

Film reference(Scene s, double seconds)
{
    s.render.method = Method::Pathtrace;
    s.render.spp = 0;
    s.render.noiseTarget = 0;
    s.render.timeLimit = seconds;
    s.render.seed = 0x5eedu;
    return render(s).film;
}

struct Run {
    double relMse = 0, l2RelMse = 0, seconds = 0;
    long long spp = 0;
};

Run timed(Scene s, Method m, double seconds, uint32_t seed, const Film& ref)
{
    s.render.method = m;
    s.render.spp = 0;
    s.render.noiseTarget = 0;
    s.render.timeLimit = seconds;
    s.render.seed = seed;
    const RenderResult r = render(s);
    Run out;
    out.relMse = measureError(r.film, ref, "beauty").relMse;
    out.l2RelMse = measureError(r.film, ref, "L2plus").relMse;
    out.seconds = r.seconds;
    if (const FilmValue* v = r.film.meta("pathtrace_spp"))
        if (const std::string* t = std::get_if<std::string>(v))
            out.spp = std::atoll(t->c_str());
    return out;
}

Run averaged(const Scene& s, Method m, double seconds, int seeds, const Film& ref)
{
    Run a;
    for (int k = 0; k < seeds; ++k) {
        const Run r = timed(s, m, seconds, 7000u + uint32_t(k), ref);
        std::fprintf(stderr, "bench_vrl:   %s seed %d: beauty relMSE %.4g, L2plus %.4g, %lld spp\n",
                     m == Method::Vrl ? "vrl" : "pathtrace", k, r.relMse, r.l2RelMse, r.spp);
        a.relMse += r.relMse / seeds;
        a.l2RelMse += r.l2RelMse / seeds;
        a.seconds += r.seconds / seeds;
        a.spp += r.spp / seeds;
    }
    return a;
}

std::string fmt(const char* f, double v)
{
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

int equalTime(const std::string& out)
{
    const double refSeconds = gReferenceSeconds > 0 ? gReferenceSeconds : gQuick ? 6 : 40, budget = gQuick ? 1 : 4;
    const int seeds = gSeeds > 0 ? gSeeds : gQuick ? 1 : 2;
    std::ostringstream md;
    md << "Equal time " << budget << " s (each render's time_limit), mean of " << seeds
       << " seeds, 48 x 48 pixels; reference: the path tracer for " << refSeconds
       << " s. relMSE is nimbus compare's (beauty and L2plus); `ratio` is vrl's beauty relMSE over the path "
          "tracer's (target <= 0.5 on the thin-to-medium scenes).\n\n";
    md << "| scene | reference floor | pathtrace spp | pathtrace beauty relMSE | pathtrace L2plus relMSE | vrl spp | "
          "vrl beauty relMSE | vrl L2plus relMSE | ratio |\n|---|---|---|---|---|---|---|---|---|\n";
    std::map<std::string, Film> refs;
    const std::vector<Named> scenes = equalTimeScenes();
    if (!gOnly.empty() &&
        std::none_of(scenes.begin(), scenes.end(), [](const Named& n) { return n.name == gOnly; })) {
        std::fprintf(stderr, "bench_vrl: --only %s: no such scene\n", gOnly.c_str());
        return 2;
    }
    for (const Named& n : scenes) {
        if (!gOnly.empty() && n.name != gOnly)
            continue;
        std::fprintf(stderr, "bench_vrl: %s: reference...\n", n.name.c_str());
        const Film ref = reference(n.scene, refSeconds);
        refs[n.name] = ref;
        const Run pt = averaged(n.scene, Method::Pathtrace, budget, seeds, ref);
        const Run vrl = averaged(n.scene, Method::Vrl, budget, seeds, ref);
        md << "| " << n.name << " (" << n.what << ") | " << fmt("%.2g", referenceNoiseRelMse(ref)) << " | " << pt.spp
           << " | " << fmt("%.3g", pt.relMse) << " | " << fmt("%.3g", pt.l2RelMse) << " | " << vrl.spp << " | "
           << fmt("%.3g", vrl.relMse) << " | " << fmt("%.3g", vrl.l2RelMse) << " | "
           << fmt("%.2f", vrl.relMse / pt.relMse) << " |\n";
        std::fprintf(stderr, "bench_vrl: %s: pathtrace %.3g, vrl %.3g\n", n.name.c_str(), pt.relMse, vrl.relMse);
    }
    md << "\nLight paths per iteration (`render.vrl_paths`), same budget and seeds, beauty relMSE:\n\n";
    md << "| scene | 1 | 4 | 16 | 64 |\n|---|---|---|---|---|\n";
    for (const Named& n : scenes) {
        if ((n.name != "haze_lamp" && n.name != "medium_sphere") || !gOnly.empty())
            continue;
        md << "| " << n.name;
        for (int paths : {1, 4, 16, 64}) {
            Scene s = n.scene;
            s.render.vrlPaths = paths;
            const Run r = averaged(s, Method::Vrl, budget, seeds, refs[n.name]);
            md << " | " << fmt("%.3g", r.relMse) << " (" << r.spp << " spp)";
        }
        md << " |\n";
    }
    std::printf("%s", md.str().c_str());
    if (!out.empty())
        bench::replaceSection(out, "vrl", md.str());
    return 0;
}

// A log-log text chart of (time, relMSE) series: one letter per series.
std::string textChart(const std::vector<std::pair<std::string, std::vector<std::pair<double, double>>>>& series)
{
    const int W = 56, H = 16;
    double x0 = 1e30, x1 = -1e30, y0 = 1e30, y1 = -1e30;
    for (const auto& s : series)
        for (const auto& [x, y] : s.second)
            if (x > 0 && y > 0) {
                x0 = std::min(x0, std::log10(x)), x1 = std::max(x1, std::log10(x));
                y0 = std::min(y0, std::log10(y)), y1 = std::max(y1, std::log10(y));
            }
    if (!(x1 > x0))
        x1 = x0 + 1;
    if (!(y1 > y0))
        y1 = y0 + 1;
    std::vector<std::string> grid(H, std::string(W, ' '));
    std::string legend;
    char mark = 'a';
    for (const auto& s : series) {
        for (const auto& [x, y] : s.second) {
            if (!(x > 0 && y > 0))
                continue;
            const int c = int(std::lround((std::log10(x) - x0) / (x1 - x0) * (W - 1)));
            const int r = int(std::lround((y1 - std::log10(y)) / (y1 - y0) * (H - 1)));
            char& cell = grid[size_t(r)][size_t(c)];
            cell = cell == ' ' ? mark : '*';
        }
        legend += std::string("  ") + mark + ": " + s.first + "\n";
        ++mark;
    }
    std::ostringstream o;
    o << "relMSE " << fmt("%.2g", std::pow(10, y1)) << "\n";
    for (const std::string& row : grid)
        o << "  |" << row << "\n";
    o << "  +" << std::string(W, '-') << "\n";
    o << "relMSE " << fmt("%.2g", std::pow(10, y0)) << "; time " << fmt("%.2g", std::pow(10, x0)) << " s to "
      << fmt("%.2g", std::pow(10, x1)) << " s (log-log; * where series overlap)\n"
      << legend;
    return o.str();
}

int oppitz(const std::string& out)
{
    const double refSeconds = gQuick ? 6 : 30;
    const std::vector<double> times = gQuick ? std::vector<double>{0.5, 1} : std::vector<double>{0.5, 1, 2, 4};
    std::ostringstream md;
    md << "A point light (intensity 10 W/sr) at the centre of a 12 m cube of homogeneous medium (sigma_s 0.3, "
          "sigma_a 0.03 per m), the camera inside it 3 m away, 40 x 40 pixels; relMSE of the beauty against the "
          "path tracer after "
       << refSeconds
       << " s, one seed per point. vrl with 1 and 10 light paths per iteration (Oppitz's \"1 light ray\" and \"10 "
          "light rays\"; nimbus has no two-direction emitter, the lamp emits uniformly), with the advanced and the "
          "simple joint distribution.\n\n";
    for (float g : {-0.9f, 0.0f, 0.9f}) {
        Scene s = baseScene(make_float3(0.4f, 0.2f, 3.0f), make_float3(0, 0, 0), 40);
        s.volumes.push_back(box(12.0f, 0.3f, 0.03f, g, 0.25));
        s.lights.push_back(point(make_float3(0, 0, 0), 10.0f));
        std::fprintf(stderr, "bench_vrl: oppitz g %g: reference...\n", g);
        const Film ref = reference(s, refSeconds);
        struct Variant {
            std::string name;
            Method m;
            int paths;
            VrlSampling sampling;
        };
        const std::vector<Variant> variants = {{"pathtrace", Method::Pathtrace, 0, VrlSampling::Auto},
                                               {"vrl advanced, 1 path", Method::Vrl, 1, VrlSampling::Advanced},
                                               {"vrl advanced, 10 paths", Method::Vrl, 10, VrlSampling::Advanced},
                                               {"vrl simple, 1 path", Method::Vrl, 1, VrlSampling::Simple},
                                               {"vrl simple, 10 paths", Method::Vrl, 10, VrlSampling::Simple}};
        std::vector<std::pair<std::string, std::vector<std::pair<double, double>>>> series;
        md << "**g = " << g << "** (reference floor " << fmt("%.2g", referenceNoiseRelMse(ref)) << ")\n\n| method |";
        for (double t : times)
            md << " t = " << t << " s |";
        md << "\n|---|";
        for (size_t i = 0; i < times.size(); ++i)
            md << "---|";
        md << "\n";
        for (const Variant& v : variants) {
            Scene sv = s;
            if (v.m == Method::Vrl) {
                sv.render.vrlPaths = v.paths;
                sv.render.vrlSampling = v.sampling;
            }
            md << "| " << v.name << " |";
            std::vector<std::pair<double, double>> pts;
            for (double t : times) {
                const Run r = timed(sv, v.m, t, 9000u, ref);
                md << " " << fmt("%.3g", r.relMse) << " (" << r.spp << " spp) |";
                pts.push_back({t, r.relMse});
            }
            md << "\n";
            series.push_back({v.name, pts});
            std::fprintf(stderr, "bench_vrl: oppitz g %g: %s done\n", g, v.name.c_str());
        }
        md << "\n```\n" << textChart(series) << "```\n\n";
    }
    std::printf("%s", md.str().c_str());
    if (!out.empty())
        bench::replaceSection(out, "vrl-oppitz", md.str());
    return 0;
}

}  // namespace

int main(int argc, char** argv)
{
    std::string mode, out;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--quick")
            gQuick = true;
        else if (a == "--seeds" && i + 1 < argc)
            gSeeds = std::max(1, std::atoi(argv[++i]));
        else if (a == "--only" && i + 1 < argc)
            gOnly = argv[++i];
        else if (a == "--reference-seconds" && i + 1 < argc)
            gReferenceSeconds = std::max(1.0, std::atof(argv[++i]));
        else if (mode.empty())
            mode = a;
        else
            out = a;
    }
    setenv("NIMBUS_CACHE_DIR", "/tmp/nimbus-bench-vrl-kernels", 0);
    if (mode == "equal-time")
        return equalTime(out);
    if (mode == "oppitz")
        return oppitz(out);
    std::fprintf(stderr, "usage: bench_vrl equal-time|oppitz [DOC.md] [--quick] [--seeds N] [--only SCENE] "
                         "[--reference-seconds S]\n");
    return 2;
}
