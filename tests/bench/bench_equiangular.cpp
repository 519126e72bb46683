// bench_equiangular: the path tracer with and without equi-angular sampling towards point and spot
// lights (render.equiangular, issue 15 item 5), at equal time, side by side in one process.
//
//   bench_equiangular [docs/benchmarks.md] [--quick]
//
// Scenes: the case, a 4 m haze box with a point light inside it; a procedural cloud under
// a sun, where equi-angular sampling has nothing to aim at (the kernel compiles without it, so
// the two renders must match in speed and error); the same cloud with a point light 2 m outside
// it, where it costs its extra ratio-tracking walks and helps little. Per scene: a reference (the
// path tracer with equi-angular sampling, its own seed, refSeconds), then `rounds` rounds of one
// render without and one with it at the same time_limit (the order alternating between rounds, so
// that load drift on a shared machine falls on both). Reported, averaged over the rounds: samples
// per pixel reached (their ratio is the speed ratio, measured side by side), beauty relMSE against
// the reference (nimbus compare's metric), the render's own relMSE estimate from its variance AOV
// (the "noise floor"), and the worst pixel's relative variance of the mean, var / (y^2 + eps), the
// firefly measure: one pixel hit by a near-light vertex. Into <!-- bench:equiangular --> of
// docs/benchmarks.md when a path is given.
#include "BenchReport.h"

#include "compare/Compare.h"
#include "engine/Renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

using namespace nimbus;

namespace {

bool gQuick = false;

Scene baseScene(float3 from, float3 to, int size)
{
    Scene s;
    s.camera.width = size;
    s.camera.height = size;
    s.camera.from = from;
    s.camera.to = to;
    s.camera.fov = 45;
    s.output.file = "unused.exr";
    s.render.method = Method::Pathtrace;
    s.render.spp = 0;
    s.render.noiseTarget = 0;
    return s;
}

Volume cloud()
{
    Volume v;
    v.name = "cloud";
    v.source.type = SourceType::Procedural;
    v.source.generator = "cloud";
    v.source.params = {{"radius", 1.0}, {"voxel_size", 0.04}, {"seed", 3}};
    v.medium.sigma_s = splat(8.0f);
    v.medium.sigma_a = splat(0.1f);
    v.medium.phase = NbPhase{0.6f, 0, 0, 0};
    return v;
}

Light sun()
{
    Light l;
    l.name = "sun";
    l.type = LightType::Distant;
    l.direction = normalize(make_float3(0.3f, -1, -0.4f));
    l.irradiance = splat(3.0f);
    return l;
}

Light lamp(float3 p, float intensity)
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

std::vector<Named> scenes()
{
    std::vector<Named> out;
    const int n = 48;
    {
        Scene s = baseScene(make_float3(0, 0.4f, 3.2f), make_float3(0, 0, 0), n);
        Volume v;
        v.name = "haze";
        v.source.type = SourceType::Procedural;
        v.source.generator = "box";
        v.source.params = {{"size", 4.0}, {"voxel_size", 0.125}};
        v.medium.sigma_s = splat(0.3f);
        v.medium.sigma_a = splat(0.03f);
        v.medium.phase = NbPhase{0.3f, 0, 0, 0};
        s.volumes.push_back(v);
        s.lights.push_back(lamp(make_float3(0.3f, 0.2f, -0.5f), 4.0f));
        out.push_back({"haze_lamp", "4 m haze box, sigma_t 0.33 per m, g 0.3, a point light inside", s});
    }
    {
        Scene s = baseScene(make_float3(0.4f, 0.3f, 3.5f), make_float3(0, 0, 0), n);
        s.volumes.push_back(cloud());
        s.lights.push_back(sun());
        out.push_back({"cloud_sun", "procedural cloud, sigma_t up to 8 per m, g 0.6, under a sun", s});
    }
    {
        Scene s = baseScene(make_float3(0.4f, 0.3f, 3.5f), make_float3(0, 0, 0), n);
        s.volumes.push_back(cloud());
        s.lights.push_back(sun());
        s.lights.push_back(lamp(make_float3(-2.5f, 1.5f, 1.0f), 8.0f));
        out.push_back({"cloud_sun_lamp", "the same cloud and sun, and a point light 2 m outside the cloud", s});
    }
    return out;
}

struct Run {
    double relMse = 0, floor = 0, worstPixel = 0;
    long long spp = 0;
};

// The largest var / (y^2 + eps) over the pixels (the summand of the noise floor's mean).
double worstPixel(const Film& f)
{
    const Aov* v = f.find("variance");
    const Aov* b = f.find("beauty");
    if (!v || !b)
        return 0;
    const size_t n = size_t(f.width) * size_t(f.height);
    std::vector<double> y(n);
    double m = 0;
    for (size_t i = 0; i < n; ++i) {
        const float* p = b->pixels.data() + i * size_t(b->channels);
        y[i] = (p[0] + p[1] + p[2]) / 3.0;
        m += y[i] / double(n);
    }
    const double eps = (0.1 * m) * (0.1 * m) + 1e-20;
    double worst = 0;
    for (size_t i = 0; i < n; ++i)
        worst = std::max(worst, v->pixels[i] / (y[i] * y[i] + eps));
    return worst;
}

Run timed(Scene s, bool equi, double seconds, uint32_t seed, const Film& ref)
{
    s.render.equiangular = equi;
    s.render.timeLimit = seconds;
    s.render.seed = seed;
    const RenderResult r = render(s);
    Run out;
    out.relMse = measureError(r.film, ref, "beauty").relMse;
    out.floor = referenceNoiseRelMse(r.film);
    out.worstPixel = worstPixel(r.film);
    if (const FilmValue* v = r.film.meta("pathtrace_spp"))
        if (const std::string* t = std::get_if<std::string>(v))
            out.spp = std::atoll(t->c_str());
    return out;
}

std::string fmt(const char* f, double v)
{
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

}  // namespace

// Per-AOV noise at equal samples: two renders of each variant with different seeds, their relMSE
// against each other (twice one render's), and where the beauty's error lies (8 x 8 blocks).
int diagnose(int spp)
{
    for (const Named& n : scenes()) {
        for (bool equi : {false, true}) {
            Scene s = n.scene;
            s.render.equiangular = equi;
            s.render.spp = spp;
            s.render.seed = 1;
            const RenderResult a = render(s);
            s.render.seed = 2;
            const RenderResult b = render(s);
            std::printf("%s %s: %d spp in %.2f s; relMSE between seeds: beauty %.3g L1 %.3g L2plus %.3g\n",
                        n.name.c_str(), equi ? "on " : "off", spp, b.seconds, measureError(a.film, b.film, "beauty").relMse,
                        measureError(a.film, b.film, "L1").relMse, measureError(a.film, b.film, "L2plus").relMse);
            const Aov* x = a.film.find("beauty");
            const Aov* y = b.film.find("beauty");
            const int W = a.film.width, H = a.film.height;
            double mean = 0;
            for (int i = 0; i < W * H; ++i)
                mean += (y->pixels[size_t(4 * i)] + y->pixels[size_t(4 * i + 1)] + y->pixels[size_t(4 * i + 2)]) / 3 / (W * H);
            const double eps = 0.01 * mean * mean;
            for (int by = 0; by < 8; ++by) {
                std::printf("   ");
                for (int bx = 0; bx < 8; ++bx) {
                    double e = 0;
                    for (int yy = by * H / 8; yy < (by + 1) * H / 8; ++yy)
                        for (int xx = bx * W / 8; xx < (bx + 1) * W / 8; ++xx) {
                            const size_t i = size_t(yy * W + xx) * 4;
                            const double u = (x->pixels[i] + x->pixels[i + 1] + x->pixels[i + 2]) / 3;
                            const double v = (y->pixels[i] + y->pixels[i + 1] + y->pixels[i + 2]) / 3;
                            e += (u - v) * (u - v) / (v * v + eps) / (W * H);
                        }
                    std::printf(" %8.2e", e);
                }
                std::printf("\n");
            }
        }
    }
    return 0;
}

int main(int argc, char** argv)
{
    std::string out;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--quick")
            gQuick = true;
        else if (a == "--diagnose")
            return diagnose(i + 1 < argc ? std::atoi(argv[i + 1]) : 64);
        else
            out = a;
    }
    const double refSeconds = gQuick ? 8 : 90, budget = gQuick ? 1 : 6;
    const int rounds = gQuick ? 1 : 3;
    std::ostringstream md;
    md << "Equal time " << budget << " s per render (its time_limit), " << rounds
       << " rounds of one render without and one with equi-angular sampling, the order alternating, 48 x 48 "
          "pixels, unbounded depth; reference: the path tracer with equi-angular sampling for "
       << refSeconds
       << " s (its own seed). `spp`: samples per pixel reached (their ratio is the speed ratio, side by side); "
          "`relMSE`: beauty against the reference (nimbus compare's metric, the reference's floor included); "
          "`floor`: the render's own relMSE estimate from its variance AOV; `worst pixel`: the largest "
          "var / (y^2 + eps) over the pixels (fireflies). Means over the rounds.\n\n";
    md << "| scene | reference floor | off spp | on spp | speed on/off | off relMSE | on relMSE | relMSE on/off | "
          "off floor | on floor | off worst pixel | on worst pixel |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Named& n : scenes()) {
        std::fprintf(stderr, "bench_equiangular: %s: reference...\n", n.name.c_str());
        Scene rs = n.scene;
        rs.render.equiangular = true;
        rs.render.timeLimit = refSeconds;
        rs.render.seed = 0x5eedu;
        const Film ref = render(rs).film;
        // Warm-up: build (or load) both kernels before anything is timed.
        for (bool equi : {false, true}) {
            Scene w = n.scene;
            w.render.equiangular = equi;
            w.render.spp = 1;
            render(w);
        }
        Run off, on;
        for (int k = 0; k < rounds; ++k) {
            for (int j = 0; j < 2; ++j) {
                const bool equi = (j == 0) == (k % 2 == 1);
                const Run r = timed(n.scene, equi, budget, 9000u + uint32_t(2 * k + j), ref);
                Run& a = equi ? on : off;
                a.relMse += r.relMse / rounds;
                a.floor += r.floor / rounds;
                a.worstPixel += r.worstPixel / rounds;
                a.spp += r.spp;
                std::fprintf(stderr, "bench_equiangular: %s %s: %lld spp, relMSE %.3g, floor %.3g, worst %.3g\n",
                             n.name.c_str(), equi ? "on" : "off", r.spp, r.relMse, r.floor, r.worstPixel);
            }
        }
        const double sppOff = double(off.spp) / rounds, sppOn = double(on.spp) / rounds;
        md << "| " << n.name << " (" << n.what << ") | " << fmt("%.2g", referenceNoiseRelMse(ref)) << " | "
           << fmt("%.0f", sppOff) << " | " << fmt("%.0f", sppOn) << " | " << fmt("%.2f", sppOn / sppOff) << " | "
           << fmt("%.3g", off.relMse) << " | " << fmt("%.3g", on.relMse) << " | " << fmt("%.2f", on.relMse / off.relMse)
           << " | " << fmt("%.3g", off.floor) << " | " << fmt("%.3g", on.floor) << " | " << fmt("%.3g", off.worstPixel)
           << " | " << fmt("%.3g", on.worstPixel) << " |\n";
    }
    std::printf("%s", md.str().c_str());
    if (!out.empty())
        bench::replaceSection(out, "equiangular", md.str());
    return 0;
}
