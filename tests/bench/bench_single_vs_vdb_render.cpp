// bench_single_vs_vdb_render: nimbus `single` against OpenVDB's vdb_render (Debian's
// libopenvdb-tools), the speed floor for single scattering (issue 2).
//
// Both render the same VDB cloud (written by nimbus's generator) at the same resolution and the
// same primary step in voxels, each from its own process, timed side by side in one run
// (median of repeats). Each renderer's step-size error is measured against its own render at a
// 1/8-voxel step: normalised RMS error = sqrt(mean (a - ref)^2) / mean(ref) over beauty RGB,
// which is independent of the two renderers' different light units.
//
// Usage: bench_single_vs_vdb_render NIMBUS_BINARY [docs/benchmarks.md] [--quick]
#include "BenchReport.h"

#include "volume/Procedural.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;

namespace {

std::vector<float> readRgb(const std::string& path, const char* layerPrefix)
{
    auto in = OIIO::ImageInput::open(path);
    if (!in)
        throw std::runtime_error("cannot read " + path);
    const OIIO::ImageSpec& spec = in->spec();
    std::vector<float> all(size_t(spec.width) * spec.height * spec.nchannels);
    in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, all.data());
    int c0 = -1;
    for (int c = 0; c < spec.nchannels; ++c)
        if (spec.channelnames[c] == std::string(layerPrefix) + "R") {
            c0 = c;
            break;
        }
    if (c0 < 0)
        throw std::runtime_error(path + ": no channel " + layerPrefix + "R");
    std::vector<float> rgb(size_t(spec.width) * spec.height * 3);
    for (size_t p = 0; p < size_t(spec.width) * spec.height; ++p)
        for (int c = 0; c < 3; ++c)
            rgb[p * 3 + c] = all[p * spec.nchannels + c0 + c];
    return rgb;
}

double normalisedRmse(const std::vector<float>& a, const std::vector<float>& ref)
{
    double se = 0, mean = 0;
    for (size_t i = 0; i < ref.size(); ++i) {
        se += double(a[i] - ref[i]) * (a[i] - ref[i]);
        mean += ref[i];
    }
    mean /= double(ref.size());
    return std::sqrt(se / double(ref.size())) / std::max(mean, 1e-30);
}

double timeCommand(const std::string& cmd)
{
    auto t0 = std::chrono::steady_clock::now();
    int rc = std::system(cmd.c_str());
    double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (rc != 0)
        throw std::runtime_error("command failed (" + std::to_string(rc) + "): " + cmd);
    return s;
}

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv)
{
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s NIMBUS_BINARY [docs/benchmarks.md] [--quick]\n", argv[0]);
        return 2;
    }
    const std::string nimbus = argv[1];
    const std::string report = argc > 2 && argv[2][0] != '-' ? argv[2] : "";
    const bool quick = std::string(argv[argc - 1]) == "--quick";
    const int repeats = quick ? 1 : 9;
    const int width = quick ? 320 : 640, height = quick ? 180 : 360;

    try {
        fs::path dir = fs::temp_directory_path() / ("nimbus-bench-" + std::to_string(::getpid()));
        fs::create_directories(dir);
        const std::string vdb = (dir / "cloud.vdb").string();

        nimbus::VolumeSource src;
        src.type = nimbus::SourceType::Procedural;
        src.generator = "cloud";
        nimbus::writeProceduralVdb(src, vdb);

        // Camera and light shared by both: vdb_render's -fov is horizontal, nimbus's vertical.
        const double vfov = 40.0, aspect = double(width) / height;
        const double hfov = 2.0 * std::atan(aspect * std::tan(vfov * M_PI / 360.0)) * 180.0 / M_PI;
        const char* eye = "0,1.2,8.5";
        // vdb_render's -light is the direction toward the light; nimbus's is the direction of travel.
        const char* toLight = "-1,1,0.7";

        auto sceneFor = [&](double step, const std::string& out) {
            std::ostringstream j;
            j << R"({"camera": {"from": [0, 1.2, 8.5], "to": [0, 0, 0], "up": [0, 1, 0], "fov": )" << vfov
              << R"(, "resolution": [)" << width << ", " << height << R"(]},
 "lights": [{"name": "key", "type": "distant", "direction": [1, -1, -0.7], "irradiance": [3, 3, 3]}],
 "volumes": [{"name": "cloud", "source": {"type": "vdb", "file": ")"
              << vdb << R"("},
   "medium": {"sigma_s": [1.5, 1.5, 1.5], "sigma_a": [0.1, 0.1, 0.1], "phase": {"type": "hg", "g": 0}}}],
 "render": {"method": "single", "spp": 1, "step": )"
              << step << R"(, "shadow_step": 3, "shadow_map_resolution": 256},
 "output": {"file": ")"
              << out << R"(", "aovs": ["beauty"]}})";
            std::string path = (dir / ("scene_" + std::to_string(step) + ".json")).string();
            std::ofstream(path) << j.str();
            return path;
        };
        auto nimbusCmd = [&](double step) {
            std::string out = (dir / ("nimbus_" + std::to_string(step) + ".exr")).string();
            return std::make_pair(nimbus + " render -q " + sceneFor(step, out), out);
        };
        auto vdbCmd = [&](double step) {
            std::string out = (dir / ("vdb_" + std::to_string(step) + ".exr")).string();
            std::ostringstream c;
            c << "vdb_render " << vdb << " " << out << " -res " << width << "x" << height << " -fov " << hfov
              << " -translate " << eye << " -lookat 0,0,0 -up 0,1,0 -light " << toLight << ",1,1,1"
              << " -scatter 1.5,1.5,1.5 -absorb 0.1,0.1,0.1 -step " << step << " -shadowstep 3 -cpus 0"
              << " > /dev/null 2>&1";
            return std::make_pair(c.str(), out);
        };

        // Load-and-render seconds as each renderer reports them (no process start-up, no image
        // write): vdb_render -v prints its reading and ray-tracing times; nimbus writes
        // nimbus:render_time (volumes loaded, shadow maps, march) into the EXR.
        auto vdbRenderSeconds = [&](const std::string& cmd) {
            std::string log = (dir / "vdb.log").string();
            std::string verbose = cmd;
            verbose.replace(verbose.find(" > /dev/null"), std::string::npos, " -v > " + log + " 2>&1");
            timeCommand(verbose);
            std::ifstream in(log);
            // -v prints "...completed in X sec" after reading, ray-tracing and writing: the first
            // two, since OpenVDB loads voxel data lazily (the read is metadata, the voxels arrive
            // during ray-tracing) and nimbus's render time includes loading its volumes.
            std::string line;
            std::vector<double> times;
            while (std::getline(in, line)) {
                size_t at = line.find("completed in ");
                if (at != std::string::npos)
                    times.push_back(std::stod(line.substr(at + 13)));
            }
            double seconds = times.size() >= 2 ? times[0] + times[1] : -1.0;
            return seconds;
        };
        auto nimbusRenderSeconds = [&](const std::string& exr) {
            auto in = OIIO::ImageInput::open(exr);
            return in ? std::stod(in->spec().get_string_attribute("nimbus:render_time", "-1")) : -1.0;
        };

        // Every configuration is timed once per round, rounds repeated, so all see the same
        // machine load; medians over rounds. Each renderer's error is against its own render at
        // a 1/8-voxel step.
        struct Run {
            std::string renderer;
            double step;
            std::string cmd, out;
            std::vector<double> wall, render;
            double error = 0;
        };
        std::vector<Run> runs;
        for (double st : {1.0, 0.5, 0.25}) {
            auto [c, out] = vdbCmd(st);
            runs.push_back({"vdb_render", st, c, out, {}, {}});
        }
        for (double st : {1.0, 1.5, 2.0, 3.0, 3.5, 4.0, 6.0, 8.0}) {
            auto [c, out] = nimbusCmd(st);
            runs.push_back({"nimbus single", st, c, out, {}, {}});
        }
        for (int r = 0; r < repeats; ++r)
            for (Run& run : runs) {
                run.wall.push_back(timeCommand(run.cmd));
                run.render.push_back(run.renderer == "vdb_render" ? vdbRenderSeconds(run.cmd)
                                                                  : nimbusRenderSeconds(run.out));
            }
        auto [nRefCmd, nRefOut] = nimbusCmd(0.125);
        auto [vRefCmd, vRefOut] = vdbCmd(0.125);
        timeCommand(nRefCmd);
        timeCommand(vRefCmd);
        const auto nRef = readRgb(nRefOut, "beauty."), vRef = readRgb(vRefOut, "");
        for (Run& run : runs) {
            run.error = run.renderer == "vdb_render" ? normalisedRmse(readRgb(run.out, ""), vRef)
                                                     : normalisedRmse(readRgb(run.out, "beauty."), nRef);
            std::fprintf(stderr, "%s step %.3g: wall %.3f render %.3f error %.4f\n", run.renderer.c_str(), run.step,
                         median(run.wall), median(run.render), run.error);
        }
        const Run& vdb1 = runs[0];
        const Run& nimbus1 = runs[3];
        // nimbus's coarsest step whose error is at or below a vdb_render run's: chosen by the
        // errors, which do not vary between runs, not by picking the least of several noisy
        // timings (which would flatter nimbus).
        auto coarsestWithin = [&](const Run& v) -> const Run* {
            const Run* best = nullptr;
            for (const Run& n : runs)
                if (n.renderer != "vdb_render" && n.error <= v.error && (!best || n.step > best->step))
                    best = &n;
            return best;
        };

        std::ostringstream md;
        char line[700];
        md << "Same VDB cloud (nimbus's `cloud` generator written to a .vdb, 144 voxels across), " << width << "x"
           << height << ", one light, shadow step 3 voxels, one ray per pixel, all cores; every configuration run "
           << "once per round, " << repeats << " rounds, medians. *Wall*: the whole process (start-up, load, render, "
           << "write). *Render*: load and render as each reports it, no start-up or image write (vdb_render -v: "
           << "reading + ray-tracing, OpenVDB loading voxels lazily during the latter; nimbus: `nimbus:render_time` = "
           << "volumes loaded + shadow maps + march). Step error: normalised RMSE of beauty against the same renderer "
           << "at a 1/8-voxel step.\n\n";
        md << "| renderer | primary step (voxels) | wall (s) | render (s) | step error |\n|---|---|---|---|---|\n";
        for (const Run& run : runs) {
            std::snprintf(line, sizeof line, "| %s | %.3g | %.3f | %.3f | %.4f |\n", run.renderer.c_str(), run.step,
                          median(run.wall), median(run.render), run.error);
            md << line;
        }
        std::snprintf(line, sizeof line,
                      "\nSame step (1 voxel): nimbus/vdb_render speed %.2fx (render), %.2fx (wall); step error %.4f "
                      "vs %.4f.  \n",
                      median(vdb1.render) / median(nimbus1.render), median(vdb1.wall) / median(nimbus1.wall),
                      nimbus1.error, vdb1.error);
        md << line;
        for (size_t i = 0; i < 3; ++i) {
            const Run& v = runs[i];
            if (const Run* n = coarsestWithin(v)) {
                std::snprintf(line, sizeof line,
                              "At or below vdb_render's error at %.3g voxels (%.4f): nimbus at %.3g voxels (%.4f), "
                              "%.2fx (render), %.2fx (wall).  \n",
                              v.step, v.error, n->step, n->error, median(v.render) / median(n->render),
                              median(v.wall) / median(n->wall));
            } else {
                std::snprintf(line, sizeof line,
                              "At or below vdb_render's error at %.3g voxels (%.4f): no nimbus step "
                              "measured reaches it.  \n",
                              v.step, v.error);
            }
            md << line;
        }
        const Run* atVdb1 = coarsestWithin(vdb1);
        const double ratio = atVdb1 ? median(vdb1.render) / median(atVdb1->render) : 0.0;
        std::snprintf(line, sizeof line,
                      "Target (issue 2): nimbus at least 3x faster than vdb_render at its 1-voxel step, at equal or "
                      "lower step error: %.2fx, %s. Start-up alone costs nimbus ~0.3 s (OpenImageIO pulls in ~240 "
                      "shared libraries through OpenCV and its codecs), which the wall figures include.\n\n",
                      ratio, ratio >= 3.0 ? "met" : "not met");
        md << line;
        md << "Rerun: `build/tests/bench/bench_single_vs_vdb_render build/bin/nimbus docs/benchmarks.md`.\n";
        std::fputs(md.str().c_str(), stdout);
        if (!report.empty())
            nimbus::bench::replaceSection(report, "single-vs-vdb_render", md.str());
        fs::remove_all(dir);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_single_vs_vdb_render: %s\n", e.what());
        return 1;
    }
    return 0;
}
