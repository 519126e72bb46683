// bench_pathtrace_vs_cycles: nimbus's path tracer against Blender's Cycles at equal wall time
// (issue 4): the noise each leaves after the same time, as relMSE against its own converged
// image. Built with the tests, never run by ctest.
//
//   bench_pathtrace_vs_cycles NIMBUS_BINARY [docs/benchmarks.md] [--quick] [--budgets 5,10,20]
//       [--seeds 3] [--reference SECONDS] [--blender PATH] [--fresh]
//
// One scene, given to both renderers through the mapping of docs/validation.md
// (cycles_render.py builds the Blender side): nimbus's `cloud` generator written to a .vdb, one
// sun, a grey medium of albedo 0.95 with HG g = 0.5, at most 16 scattering events per path, a
// one-pixel box filter, 200x150 pixels, the same number of CPU threads.
//
// Time counted. Each renderer is timed over its render call: nimbus's render() (the CLI's
// `nimbus:render_time`: VDB read, brick grid, OpenCL set-up and cached kernel, sampling,
// read-back) and Cycles' bpy.ops.render.render() (the VDB read, scene sync, sampling, read-back).
// Process start-up (Blender's ~1-2 s, nimbus's ~0.3 s), scene set-up and writing the EXR are left
// out for both. Both renderers' time limits count sampling only, so each gets the limit
// `budget - overhead`, its overhead measured by a 2 s calibration run: the render calls then
// last the budget. The measured seconds are reported, and the ratio is also given normalised by
// them (relMSE * seconds: the inverse efficiency), which cancels what is left of the mismatch.
//
// Noise. relMSE = mean over pixels and RGB channels of (x - ref)^2 / (ref^2 + eps), eps =
// (0.1 mean(ref))^2 (nimbus compare's definition, src/compare/Compare.h), ref the renderer's
// own long render (`--reference` seconds, the same for both, cached in the build directory
// keyed by the scene, the binaries and the kernels). Its own noise adds a fraction
// spp / spp_ref to every relMSE (a few percent; reported). Runs alternate between the renderers
// (and which goes first) so that both see the same load; a render call that misses its budget
// by over 10% is run again.
#include "BenchReport.h"

#include "volume/Procedural.h"

#include <OpenImageIO/imageio.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The scene, in Blender's world axes (both renderers take them as they are).
struct BenchScene {
    int width = 200, height = 150;
    double from[3] = {3.0, 1.1, 4.2}, to[3] = {0.0, 0.15, 0.0}, up[3] = {0.0, 1.0, 0.0};
    double fov = 25.0;                                  // vertical, degrees
    double sunDirection[3] = {0.6, -0.6, -0.3};         // of travel
    double irradiance = 3.0;                            // W/m^2
    double densityScale = 8.0, albedo = 0.95, g = 0.5;  // sigma_t = 8/m at density 1
    int maxDepth = 16;                                  // scattering events per path
    double cloudRadius = 1.0;                           // m; ~145 voxels across
};

json vec3(const double (&v)[3])
{
    return json::array({v[0], v[1], v[2]});
}

json nimbusScene(const BenchScene& s, const std::string& vdb, const std::string& out, int seed, double timeLimit,
                 int threads)
{
    const double a = s.albedo;
    return {{"camera",
             {{"from", vec3(s.from)},
              {"to", vec3(s.to)},
              {"up", vec3(s.up)},
              {"fov", s.fov},
              {"resolution", {s.width, s.height}}}},
            {"lights",
             {{{"name", "sun"},
               {"type", "distant"},
               {"direction", vec3(s.sunDirection)},
               {"irradiance", {s.irradiance, s.irradiance, s.irradiance}},
               {"angle", 0.0}}}},
            {"volumes",
             {{{"name", "cloud"},
               {"source", {{"type", "vdb"}, {"file", vdb}}},
               {"medium",
                {{"sigma_s", {a, a, a}},
                 {"sigma_a", {1 - a, 1 - a, 1 - a}},
                 {"density_scale", s.densityScale},
                 {"phase", {{"type", "hg"}, {"g", s.g}}}}}}}},
            {"render",
             {{"method", "pathtrace"},
              {"spp", 1000000000},  // the time limit stops it (the scene format requires spp >= 1)
              {"max_depth", s.maxDepth},
              {"time_limit", timeLimit},
              {"seed", seed},
              {"threads", threads}}},
            {"output", {{"file", out}, {"aovs", {"beauty"}}}}};
}

json cyclesSpec(const BenchScene& s, const std::string& vdb, const std::string& out, const std::string& result,
                int seed, double timeLimit, int threads)
{
    return {{"vdb", vdb},
            {"camera",
             {{"from", vec3(s.from)},
              {"to", vec3(s.to)},
              {"up", vec3(s.up)},
              {"fov", s.fov},
              {"resolution", {s.width, s.height}}}},
            {"sun", {{"direction", vec3(s.sunDirection)}, {"irradiance", s.irradiance}}},
            {"medium", {{"density_scale", s.densityScale}, {"albedo", s.albedo}, {"g", s.g}}},
            {"max_depth", s.maxDepth},
            {"seed", seed},
            {"time_limit", timeLimit},
            {"samples", 1 << 24},  // Cycles' maximum: the time limit stops it
            {"threads", threads},
            {"output", out},
            {"result", result}};
}

std::string readFile(const fs::path& p)
{
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

uint64_t fnv1a(const std::string& s, uint64_t h = 1469598103934665603ull)
{
    for (unsigned char c : s)
        h = (h ^ c) * 1099511628211ull;
    return h;
}

std::string hex(uint64_t v)
{
    char b[17];
    std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(v));
    return b;
}

std::string quote(const std::string& s)
{
    return "'" + s + "'";
}  // paths here hold no quotes

double runCommand(const std::string& cmd, const std::string& log)
{
    auto t0 = std::chrono::steady_clock::now();
    int rc = std::system((cmd + " > " + quote(log) + " 2>&1").c_str());
    double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (rc != 0)
        throw std::runtime_error("command failed (" + std::to_string(rc) + "), see " + log + ": " + cmd);
    return s;
}

std::string firstLineOf(const std::string& cmd)
{
    std::string out;
    if (FILE* p = popen(cmd.c_str(), "r")) {
        char buf[512];
        if (fgets(buf, sizeof buf, p))
            out = buf;
        pclose(p);
    }
    while (!out.empty() && (out.back() == '\n' || out.back() == '\r'))
        out.pop_back();
    return out;
}

// Samples per pixel Cycles reached: the largest N of its progress lines "Sample N/M" (N counts
// finished samples). Its EXR metadata (cycles.ViewLayer.samples) holds the requested M when the
// time limit stops it, so it cannot tell.
long long cyclesSamples(const std::string& log)
{
    long long best = -1;
    for (size_t at = log.find("Sample "); at != std::string::npos; at = log.find("Sample ", at + 7)) {
        size_t end = at + 7;
        while (end < log.size() && std::isdigit(static_cast<unsigned char>(log[end])))
            ++end;
        if (end > at + 7 && end < log.size() && log[end] == '/')
            best = std::max(best, std::stoll(log.substr(at + 7, end - at - 7)));
    }
    return best;
}

struct Image {
    std::vector<float> rgb;  // width * height * 3
    std::string meta(const char* key) const
    {
        for (const auto& [k, v] : attributes)
            if (k == key)
                return v;
        return "";
    }
    std::vector<std::pair<std::string, std::string>> attributes;
};

// The RGB of `prefix`R/G/B ("" for Cycles' plain RGBA, "beauty." for nimbus).
Image readImage(const std::string& path, const std::string& prefix, int width, int height)
{
    auto in = OIIO::ImageInput::open(path);
    if (!in)
        throw std::runtime_error("cannot read " + path);
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width != width || spec.height != height)
        throw std::runtime_error(path + ": unexpected size");
    std::vector<float> all(size_t(spec.width) * spec.height * spec.nchannels);
    in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, all.data());
    int c0 = -1;
    for (int c = 0; c + 2 < spec.nchannels && c0 < 0; ++c)
        if (spec.channelnames[c] == prefix + "R" && spec.channelnames[c + 1] == prefix + "G" &&
            spec.channelnames[c + 2] == prefix + "B")
            c0 = c;
    if (c0 < 0)
        throw std::runtime_error(path + ": no channels " + prefix + "R/G/B");
    Image img;
    img.rgb.resize(size_t(width) * height * 3);
    for (size_t p = 0; p < size_t(width) * height; ++p)
        for (int c = 0; c < 3; ++c)
            img.rgb[p * 3 + c] = all[p * spec.nchannels + c0 + c];
    for (const auto& a : spec.extra_attribs)
        img.attributes.push_back({a.name().string(), a.get_string()});
    return img;
}

double mean(const std::vector<float>& v)
{
    double s = 0;
    for (float x : v)
        s += x;
    return v.empty() ? 0.0 : s / double(v.size());
}

// nimbus compare's relMSE (src/compare/Compare.h): eps = (0.1 mean(ref))^2.
double relMse(const std::vector<float>& x, const std::vector<float>& ref)
{
    const double m = mean(ref), eps = std::max((0.1 * m) * (0.1 * m), 1e-20);
    double s = 0;
    for (size_t i = 0; i < ref.size(); ++i) {
        const double d = double(x[i]) - ref[i];
        s += d * d / (double(ref[i]) * ref[i] + eps);
    }
    return s / double(ref.size());
}

// The share of relMSE held by its largest 0.1% of terms (pixel channels): how much of the noise
// is rare outliers (fireflies) rather than grain spread over the image.
double tailShare(const std::vector<float>& x, const std::vector<float>& ref)
{
    const double m = mean(ref), eps = std::max((0.1 * m) * (0.1 * m), 1e-20);
    std::vector<double> terms(ref.size());
    double total = 0;
    for (size_t i = 0; i < ref.size(); ++i) {
        const double d = double(x[i]) - ref[i];
        terms[i] = d * d / (double(ref[i]) * ref[i] + eps);
        total += terms[i];
    }
    const size_t k = std::max<size_t>(1, terms.size() / 1000);
    std::nth_element(terms.begin(), terms.end() - k, terms.end());
    double tail = 0;
    for (size_t i = terms.size() - k; i < terms.size(); ++i)
        tail += terms[i];
    return total > 0 ? tail / total : 0.0;
}

struct Run {
    double renderSeconds = 0;   // the render call
    double processSeconds = 0;  // the whole process, start-up and EXR writing included
    long long spp = 0;
    std::string exr;
};

struct Stat {
    double mean = 0, sem = 0;  // standard error of the mean over seeds
};

Stat stat(const std::vector<double>& v)
{
    Stat s;
    for (double x : v)
        s.mean += x;
    s.mean /= double(v.size());
    if (v.size() > 1) {
        double q = 0;
        for (double x : v)
            q += (x - s.mean) * (x - s.mean);
        s.sem = std::sqrt(q / double(v.size() - 1) / double(v.size()));
    }
    return s;
}

std::vector<double> parseList(const std::string& s)
{
    std::vector<double> v;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        v.push_back(std::stod(item));
    return v;
}

std::string findBlender(const std::string& given)
{
    if (!given.empty())
        return fs::exists(given) ? given : "";
    if (const char* env = std::getenv("BLENDER"); env && *env)
        return fs::exists(env) ? env : "";
    const char* path = std::getenv("PATH");
    std::stringstream ss(path ? path : "");
    std::string dir;
    while (std::getline(ss, dir, ':'))
        if (!dir.empty() && fs::exists(fs::path(dir) / "blender"))
            return (fs::path(dir) / "blender").string();
    return "";
}

std::string num(const char* f, double v)
{
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

}  // namespace

int main(int argc, char** argv)
{
    if (argc < 2) {
        std::fprintf(stderr,
                     "usage: %s NIMBUS_BINARY [docs/benchmarks.md] [--quick] [--budgets 5,10,20] [--seeds 3] "
                     "[--reference SECONDS] [--blender PATH] [--fresh]\n",
                     argv[0]);
        return 2;
    }
    const std::string nimbus = fs::absolute(argv[1]).string();
    std::string report, blenderArg;
    bool quick = false, fresh = false;
    std::vector<double> budgets = {5, 10, 20};
    int seeds = 3;
    double referenceSeconds = 600;
    for (int i = 2; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc)
                throw std::invalid_argument(a + " needs a value");
            return argv[++i];
        };
        try {
            if (a == "--quick")
                quick = true, budgets = {2, 4}, seeds = 1, referenceSeconds = 60;
            else if (a == "--fresh")
                fresh = true;
            else if (a == "--budgets")
                budgets = parseList(next());
            else if (a == "--seeds")
                seeds = std::stoi(next());
            else if (a == "--reference")
                referenceSeconds = std::stod(next());
            else if (a == "--blender")
                blenderArg = next();
            else if (!a.empty() && a[0] != '-')
                report = a;
            else
                throw std::invalid_argument("unknown option " + a);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "bench_pathtrace_vs_cycles: %s\n", e.what());
            return 2;
        }
    }

    const std::string blender = findBlender(blenderArg);
    if (blender.empty()) {
        std::printf("bench_pathtrace_vs_cycles: skipped: blender not found (--blender, $BLENDER or PATH; "
                    "scripts/install-deps.sh installs Debian's)\n");
        return 0;
    }

    try {
        const BenchScene scene;
        const int threads = int(std::max(1u, std::thread::hardware_concurrency()));
        const int pixels = scene.width * scene.height;
        const fs::path source = NIMBUS_SOURCE_DIR;
        const fs::path script = source / "tests" / "bench" / "cycles_render.py";
        const fs::path dir = fs::absolute(NIMBUS_BENCH_CACHE_DIR);
        fs::create_directories(dir);
        const std::string vdb = (dir / "cloud.vdb").string();
        const std::string pocl = "POCL_MAX_PTHREAD_COUNT=" + std::to_string(threads) + " ";

        nimbus::VolumeSource cloud;
        cloud.type = nimbus::SourceType::Procedural;
        cloud.generator = "cloud";
        cloud.params["radius"] = scene.cloudRadius;
        nimbus::writeProceduralVdb(cloud, vdb);

        const std::string blenderVersion = firstLineOf(quote(blender) + " --version 2>/dev/null");
        // The source tree's commit names what was measured (empty outside a git checkout).
        const std::string commit =
            firstLineOf("git -C " + quote(source.string()) + " describe --always --dirty 2>/dev/null");
        const std::string nimbusVersion =
            firstLineOf(quote(nimbus) + " --version 2>&1") + (commit.empty() ? "" : " at " + commit);
        std::printf("bench_pathtrace_vs_cycles: %s against %s, %d threads, work in %s\n", nimbusVersion.c_str(),
                    blenderVersion.c_str(), threads, dir.c_str());

        auto renderNimbus = [&](const std::string& tag, int seed, double timeLimit) {
            Run r;
            r.exr = (dir / ("nimbus_" + tag + ".exr")).string();
            const fs::path scenePath = dir / ("nimbus_" + tag + ".json");
            std::ofstream(scenePath) << nimbusScene(scene, vdb, r.exr, seed, timeLimit, threads).dump(1);
            r.processSeconds = runCommand(pocl + quote(nimbus) + " render -q " + quote(scenePath.string()),
                                          (dir / ("nimbus_" + tag + ".log")).string());
            Image img = readImage(r.exr, "beauty.", scene.width, scene.height);
            r.renderSeconds = std::stod(img.meta("nimbus:render_time"));
            r.spp = std::stoll(img.meta("nimbus:pathtrace_spp"));
            return r;
        };
        auto renderCycles = [&](const std::string& tag, int seed, double timeLimit) {
            Run r;
            r.exr = (dir / ("cycles_" + tag + ".exr")).string();
            const fs::path specPath = dir / ("cycles_" + tag + ".json");
            const fs::path resultPath = dir / ("cycles_" + tag + "_result.json");
            fs::remove(resultPath);
            std::ofstream(specPath)
                << cyclesSpec(scene, vdb, r.exr, resultPath.string(), seed, timeLimit, threads).dump(1);
            const std::string log = (dir / ("cycles_" + tag + ".log")).string();
            r.processSeconds =
                runCommand(quote(blender) + " -b --factory-startup -noaudio --python-exit-code 1 --python " +
                               quote(script.string()) + " -- " + quote(specPath.string()),
                           log);
            r.renderSeconds = json::parse(readFile(resultPath)).at("render_seconds").get<double>();
            r.spp = cyclesSamples(readFile(log));
            return r;
        };

        // Each reference is reused while everything it depends on is unchanged: the scene, the
        // binaries, nimbus's kernels (read at run time: $NIMBUS_KERNEL_DIR, else the source tree's)
        // and the Blender script.
        const char* kernelDir = std::getenv("NIMBUS_KERNEL_DIR");
        std::string kernels;
        for (const auto& e :
             fs::recursive_directory_iterator(kernelDir && *kernelDir ? fs::path(kernelDir) : source / "kernels"))
            if (e.is_regular_file())
                kernels += e.path().string() + readFile(e.path());
        // OpenVDB writes a random file UUID, 36 characters after the 21 bytes of magic and versions:
        // the cloud's key leaves it out.
        std::string cloudBytes = readFile(vdb);
        if (cloudBytes.size() > 57)
            cloudBytes.replace(21, 36, 36, '-');
        const std::string sceneKey = nimbusScene(scene, "", "", 0, 0, threads).dump() +
                                     cyclesSpec(scene, "", "", "", 0, 0, threads).dump() + cloudBytes +
                                     std::to_string(referenceSeconds);
        const std::string nimbusKey = hex(fnv1a(sceneKey + readFile(nimbus) + kernels));
        const std::string cyclesKey = hex(fnv1a(sceneKey + blenderVersion + readFile(blender) + readFile(script)));
        auto reference = [&](const std::string& who, const std::string& key, auto&& render) {
            const fs::path exr = dir / (who + "_ref_" + key + ".exr"), meta = dir / (who + "_ref_" + key + ".json");
            if (!fresh && fs::exists(exr) && fs::exists(meta)) {
                json m = json::parse(readFile(meta));
                std::printf("  %s reference: cached (%s)\n", who.c_str(), exr.c_str());
                return Run{m.at("render_seconds").get<double>(), m.at("process_seconds").get<double>(),
                           m.at("spp").get<long long>(), exr.string()};
            }
            std::printf("  %s reference: rendering %.0f s into %s...\n", who.c_str(), referenceSeconds, exr.c_str());
            std::fflush(stdout);
            Run r = render("ref", 1000, referenceSeconds);
            fs::rename(r.exr, exr);
            r.exr = exr.string();
            std::ofstream(meta) << json{
                {"render_seconds", r.renderSeconds},
                {"process_seconds", r.processSeconds},
                {"spp", r.spp}}.dump();
            return r;
        };

        double load0[3] = {0, 0, 0};
        getloadavg(load0, 3);
        const Run nRef = reference("nimbus", nimbusKey, renderNimbus);
        const Run cRef = reference("cycles", cyclesKey, renderCycles);
        const Image nRefImg = readImage(nRef.exr, "beauty.", scene.width, scene.height);
        const Image cRefImg = readImage(cRef.exr, "", scene.width, scene.height);

        // Calibration: the render call's time beyond the time limit (set-up, the last pass's
        // overshoot), with a 2 s limit; and the fixed set-up alone, from a 1-sample-sized limit.
        const double calibration = 2.0;
        // The shortest runs go first: they also warm the file cache and nimbus's kernel cache.
        const Run nMin = renderNimbus("min", 901, 1e-3), cMin = renderCycles("min", 901, 1e-3);
        const Run nCal = renderNimbus("cal", 900, calibration), cCal = renderCycles("cal", 900, calibration);
        const double nOver = nCal.renderSeconds - calibration, cOver = cCal.renderSeconds - calibration;
        std::printf("  overhead beyond the limit: nimbus %.2f s, Cycles %.2f s; shortest render call: nimbus %.2f s "
                    "(%lld spp), Cycles %.2f s (%lld spp)\n",
                    nOver, cOver, nMin.renderSeconds, nMin.spp, cMin.renderSeconds, cMin.spp);

        struct Row {
            double budget;
            std::vector<double> nErr, cErr, nSec, cSec, nSpp, cSpp, nProc, cProc;
        };
        std::vector<Row> rows;
        std::vector<double> tails[2];  // nimbus, Cycles
        int order = 0, reruns[2] = {0, 0};
        for (double budget : budgets) {
            Row row{budget, {}, {}, {}, {}, {}, {}, {}, {}};
            for (int s = 0; s < seeds; ++s) {
                const int seed = 1 + s;
                const std::string tag = num("%g", budget) + "s_" + std::to_string(seed);
                Run n, c;
                // A render call that misses the budget by over 10% is run again (twice at most): Cycles
                // schedules samples in batches sized from its first sample's time, and a change of
                // load during a batch overshoots its limit (once by 86%).
                auto timed = [&](auto&& render, double over, int& again) {
                    Run r = render(tag, seed, std::max(0.05, budget - over));
                    for (int k = 0; k < 2 && std::abs(r.renderSeconds - budget) > 0.1 * budget; ++k, ++again)
                        r = render(tag, seed, std::max(0.05, budget - over));
                    return r;
                };
                auto doNimbus = [&] { n = timed(renderNimbus, nOver, reruns[0]); };
                auto doCycles = [&] { c = timed(renderCycles, cOver, reruns[1]); };
                if (order++ % 2 == 0)
                    doNimbus(), doCycles();
                else
                    doCycles(), doNimbus();
                const std::vector<float> xn = readImage(n.exr, "beauty.", scene.width, scene.height).rgb;
                const std::vector<float> xc = readImage(c.exr, "", scene.width, scene.height).rgb;
                const double en = relMse(xn, nRefImg.rgb), ec = relMse(xc, cRefImg.rgb);
                tails[0].push_back(tailShare(xn, nRefImg.rgb)), tails[1].push_back(tailShare(xc, cRefImg.rgb));
                row.nErr.push_back(en), row.cErr.push_back(ec);
                row.nSec.push_back(n.renderSeconds), row.cSec.push_back(c.renderSeconds);
                row.nSpp.push_back(double(n.spp)), row.cSpp.push_back(double(c.spp));
                row.nProc.push_back(n.processSeconds), row.cProc.push_back(c.processSeconds);
                std::printf("  budget %g s seed %d: nimbus %.2f s %lld spp relMSE %.4g | Cycles %.2f s %lld spp relMSE "
                            "%.4g\n",
                            budget, seed, n.renderSeconds, n.spp, en, c.renderSeconds, c.spp, ec);
                std::fflush(stdout);
            }
            rows.push_back(row);
        }
        double load1[3] = {0, 0, 0};
        getloadavg(load1, 3);

        // Means of the two references (the same scene must give the same radiance, ~1%:
        // docs/validation.md) and each renderer's cost and noise per sample.
        double nm[3] = {0, 0, 0}, cm[3] = {0, 0, 0};
        for (int p = 0; p < pixels; ++p)
            for (int c = 0; c < 3; ++c)
                nm[c] += nRefImg.rgb[size_t(p) * 3 + c] / pixels, cm[c] += cRefImg.rgb[size_t(p) * 3 + c] / pixels;

        std::ostringstream md;
        md << "nimbus `pathtrace` (" << nimbusVersion << ", OpenCL on PoCL, " << threads << " CPU threads) against "
           << blenderVersion << "'s Cycles (CPU, " << threads
           << " threads), the same VDB cloud (nimbus's `cloud` generator, radius " << scene.cloudRadius
           << " m, ~145 voxels across, written to a .vdb), one sun (irradiance " << scene.irradiance
           << " W/m^2), a grey medium (sigma_t " << scene.densityScale << "/m at density 1, albedo " << scene.albedo
           << ", HG g " << scene.g << "), at most " << scene.maxDepth
           << " scattering events (Cycles: " << scene.maxDepth - 1
           << " volume bounces) with each renderer's own Russian roulette, " << scene.width << "x" << scene.height
           << " pixels, one-pixel box filter; Cycles without denoising, adaptive sampling or clamping, its other "
              "settings default (volume step rate 1, Sobol-Burley samples). The Blender scene is built by "
              "`tests/bench/cycles_render.py` with the mapping of docs/validation.md.\n\n";
        md << "**Time**: the render call of each, side by side in one run, nimbus and Cycles alternating: nimbus's "
              "`render()` (`nimbus:render_time`: VDB read, brick grid, OpenCL set-up, cached kernel, sampling, "
              "read-back) and Cycles' `bpy.ops.render.render()` (VDB read, sync, sampling, read-back). Process "
              "start-up, scene set-up and EXR writing are excluded for both. Each renderer's time limit (sampling "
              "only, in both) is the budget less its overhead measured by a calibration run: nimbus "
           << num("%.2f", nOver) << " s, Cycles " << num("%.2f", cOver) << " s (the shortest render calls: nimbus "
           << num("%.2f", nMin.renderSeconds) << " s, Cycles " << num("%.2f", cMin.renderSeconds)
           << " s). *process*: the whole process (start-up, scene set-up, render, EXR writing), for information.\n\n";
        md << "**Noise**: relMSE = mean over pixels and RGB of (x - ref)^2 / (ref^2 + eps), eps = (0.1 mean(ref))^2 "
              "(as `nimbus compare`), ref the same renderer's own "
           << num("%.0f", referenceSeconds) << " s render (nimbus " << nRef.spp << " spp, Cycles " << cRef.spp
           << " spp; other seeds). Its noise adds spp/spp_ref to each relMSE: at the " << num("%g", rows.back().budget)
           << " s budget " << num("%.1f", 100 * stat(rows.back().nSpp).mean / double(nRef.spp)) << "% for nimbus, "
           << num("%.1f", 100 * stat(rows.back().cSpp).mean / double(cRef.spp)) << "% for Cycles. Mean of " << seeds
           << " seeds +- standard error. Reference means (RGB): nimbus " << num("%.5f", nm[0]) << ", Cycles "
           << num("%.5f", cm[0]) << " (Cycles/nimbus " << num("%.3f", cm[0] / nm[0]) << "): the same image.\n\n";
        md << "| budget (s) | renderer | render call (s) | process (s) | spp reached | relMSE | nimbus/Cycles relMSE | "
              "time-normalised |\n|---|---|---|---|---|---|---|---|\n";
        bool met = true;
        double worst = 0;
        std::vector<double> sppRatio;
        for (const Row& r : rows) {
            Stat en = stat(r.nErr), ec = stat(r.cErr), tn = stat(r.nSec), tc = stat(r.cSec);
            Stat sn = stat(r.nSpp), sc = stat(r.cSpp), pn = stat(r.nProc), pc = stat(r.cProc);
            const double ratio = en.mean / ec.mean, timed = ratio * tn.mean / tc.mean;
            met = met && ratio <= 1.0;
            worst = std::max(worst, ratio);
            sppRatio.push_back(sn.mean / sc.mean);
            char line[512];
            std::snprintf(line, sizeof line,
                          "| %g | nimbus | %.2f | %.2f | %.0f | %.4g +- %.2g | %.3f | %.3f |\n"
                          "| %g | Cycles | %.2f | %.2f | %.0f | %.4g +- %.2g | | |\n",
                          r.budget, tn.mean, pn.mean, sn.mean, en.mean, en.sem, ratio, timed, r.budget, tc.mean,
                          pc.mean, sc.mean, ec.mean, ec.sem);
            md << line;
        }

        // Why: sampling speed at the largest budget, where the set-up weighs least, and the noise
        // of one sample per pixel, v in relMSE = v (1/spp + 1/spp_ref) (the reference's own noise
        // taken out), over every run.
        auto profile = [&](bool isNimbus) {
            const Row& last = rows.back();
            const Stat spp = stat(isNimbus ? last.nSpp : last.cSpp), sec = stat(isNimbus ? last.nSec : last.cSec);
            const double refSpp = double((isNimbus ? nRef : cRef).spp);
            std::vector<double> v;
            for (const Row& r : rows)
                for (size_t k = 0; k < r.nErr.size(); ++k) {
                    const double n = isNimbus ? r.nSpp[k] : r.cSpp[k];
                    v.push_back((isNimbus ? r.nErr[k] : r.cErr[k]) / (1.0 / n + 1.0 / refSpp));
                }
            return std::array<double, 2>{spp.mean * pixels / sec.mean, stat(v).mean};
        };
        const auto pn = profile(true), pc = profile(false);
        const double sppAtEqualTime = stat(sppRatio).mean;
        md << "\n*nimbus/Cycles relMSE*: at equal budget; *time-normalised*: the same times the ratio of the measured "
              "render calls (relMSE x seconds, which relMSE ~ 1/t makes independent of the exact times). Runs whose "
              "render call missed the budget by over 10%, run again: nimbus "
           << reruns[0] << ", Cycles " << reruns[1] << ".\n\n";
        md << "Where the difference comes from. Sampling speed at the " << num("%g", rows.back().budget)
           << " s budget (spp x pixels / render call): nimbus " << num("%.0f", pn[0]) << " path samples/s, Cycles "
           << num("%.0f", pc[0]) << " (nimbus/Cycles " << num("%.1f", pn[0] / pc[0])
           << "); at equal budget nimbus reached " << num("%.1f", sppAtEqualTime)
           << "x Cycles' spp. Noise of one sample per pixel (v in relMSE = v (1/spp + 1/spp_ref)): nimbus "
           << num("%.3g", pn[1]) << ", Cycles " << num("%.3g", pc[1]) << " (nimbus/Cycles "
           << num("%.2f", pn[1] / pc[1])
           << "). The relMSE ratio is about the second over the first: " << num("%.2f", pn[1] / pc[1]) << " / "
           << num("%.1f", sppAtEqualTime) << " = " << num("%.3f", pn[1] / pc[1] / sppAtEqualTime)
           << ". The largest 0.1% of the relMSE terms (pixel channels) hold " << num("%.0f", 100 * stat(tails[0]).mean)
           << "% of nimbus's relMSE and " << num("%.0f", 100 * stat(tails[1]).mean)
           << "% of Cycles' (rare bright samples, fireflies).\n\n";
        md << "Load average (1 min) " << num("%.2f", load0[0]) << " at the start, " << num("%.2f", load1[0])
           << " at the end.\n\n";
        md << "Target (nimbus relMSE <= Cycles relMSE at equal time, every budget): "
           << (met ? "**met**" : "**not met**") << " (worst nimbus/Cycles ratio " << num("%.2f", worst) << ").\n\n";
        md << "Rerun: `build/tests/bench/bench_pathtrace_vs_cycles build/bin/nimbus docs/benchmarks.md` (references "
              "cached in `build/tests/bench/pathtrace_vs_cycles/`; `--fresh` renders them again, `--quick` for a "
              "short check; skipped without `blender`).\n";
        std::fputs(md.str().c_str(), stdout);
        if (!report.empty() && !quick)
            nimbus::bench::replaceSection(report, "pathtrace-vs-cycles", md.str());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_pathtrace_vs_cycles: %s\n", e.what());
        return 1;
    }
    return 0;
}
