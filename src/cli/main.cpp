// nimbus: the command-line renderer.
//
//   nimbus render SCENE.json [-o out.exr] [--method single|wkb|pathtrace] [--set key.path=value]...
//   nimbus render --default            the embedded default scene (a procedural cloud)
//   nimbus info SCENE.json             scene summary and render plan
//   nimbus devices                     OpenCL devices for the path tracer
//   render flags for the preview:      --preview-view VIEW, --preview-look LOOK, --exposure STOPS
//   render flags for the path tracer:  --device N|NAME, --checkpoint SECONDS (to <name>.partial.exr)
//   render flags for shots:            --frame N, --frames 1-240 | 1-240x2 | 1,5,9-12, --skip-missing
//                                      (frame tokens $F, $F4, #### in paths: docs/sequences.md)
//   render flags for farms:            --tile I/N, --samples A-B (pathtrace), --resume (pathtrace)
//   nimbus merge OUT.exr PARTS...      tiles and sample splits back into the frame (docs/farm.md)
//   nimbus farm plan SCENE.json --frames 1-24 [--tiles N] [--sample-splits K]   the job as JSON
//   nimbus farm submit SCENE.json --frames 1-24 ... --engine slurm              Slurm job arrays
//   nimbus default-scene               prints the default scene as JSON
//   nimbus compare SCENE.json [--out DIR] [--minutes M] [--reference-minutes R] [--seeds K] [--full]   WKB vs path tracer
//
// Exit codes: 0 success, 1 render failure, 2 bad input (a missing file or grid, bad JSON, an
// unknown key, a value out of range, a bad flag). Errors are one line on stderr.
#include "compare/Compare.h"
#include "core/Error.h"
#include "core/Log.h"
#include "core/OneLine.h"
#include "engine/Renderer.h"
#include "farm/FarmPlan.h"
#include "farm/SlurmSubmit.h"
#include "io/ExrWriter.h"
#include "io/Merge.h"
#include "io/Outputs.h"
#include "io/Progress.h"
#include "io/Resume.h"
#include "io/TempFiles.h"
#include "pathtracer/PathtraceState.h"
#include "pathtracer/Pathtracer.h"
#include "render/ShadowMapCache.h"
#include "scene/DefaultScene.h"
#include "scene/FrameList.h"
#include "scene/FrameTokens.h"
#include "scene/SceneJson.h"
#include "scene/SceneValidate.h"
#include "volume/InputFiles.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

using namespace nimbus;

namespace {

enum Exit { kOk = 0, kRenderFailure = 1, kBadInput = 2 };

struct SceneArgs {
    std::string file;
    bool useDefault = false;
    std::vector<std::string> sets;
    std::string method;
    // Shorthands for --set output.preview_view=..., output.preview_look=..., output.exposure=...
    std::string previewView, previewLook, exposure;
};

Scene loadScene(const SceneArgs& a)
{
    if (a.useDefault == !a.file.empty())
        throw InputError(a.useDefault ? "give either a scene file or --default, not both"
                                      : "no scene: give a scene file or --default");
    std::vector<std::string> overrides = a.sets;
    if (!a.method.empty())
        overrides.push_back("render.method=\"" + a.method + "\"");
    if (!a.previewView.empty())
        overrides.push_back("output.preview_view=" + nlohmann::json(a.previewView).dump());
    if (!a.previewLook.empty())
        overrides.push_back("output.preview_look=" + nlohmann::json(a.previewLook).dump());
    if (!a.exposure.empty())
        overrides.push_back("output.exposure=" + a.exposure);
    if (a.useDefault) {
        nlohmann::json j = sceneToJson(defaultScene());
        applyOverrides(j, overrides, "default scene");
        return sceneFromJson(j, "");
    }
    return loadSceneFile(a.file, overrides);
}

void addSceneArgs(CLI::App* cmd, SceneArgs& a)
{
    cmd->add_option("scene", a.file, "Scene file (JSON)");
    cmd->add_flag("--default", a.useDefault, "Use the embedded default scene");
    cmd->add_option("--set", a.sets, "Override a scene value: key.path=value (JSON value)")->take_all();
    cmd->add_option("--method", a.method, "single | wkb | pathtrace | vrl")
        ->check(CLI::IsMember({"single", "wkb", "pathtrace", "vrl"}));
}

// The preview controls: shorthands for --set output.preview_view=... and so on.
void addPreviewArgs(CLI::App* cmd, SceneArgs& a)
{
    cmd->add_option("--preview-view", a.previewView,
                    "Preview: OCIO view of the display (output.preview_view; the config is $OCIO or the shipped one)");
    cmd->add_option("--preview-look", a.previewLook,
                    "Preview: OCIO look applied before the view (output.preview_look)");
    cmd->add_option("--exposure", a.exposure, "Preview: exposure in stops, before the view (output.exposure)");
}

// -o and --preview as given: `set` tells "-o ''" (an error) from no -o at all.
struct OutputArgs {
    std::string output, preview;
    bool outputSet = false, previewSet = false;
};

struct PathtraceArgs {
    std::string device;
    double checkpointSeconds = 0;
    bool resume = false;
};

// --tile I/N and --samples A-B (docs/farm.md): one part of a frame.
struct SplitArgs {
    std::string tile, samples;
    int tileIndex = 0, tileCount = 0;    // 0/0: the whole frame
    bool split = false;                  // --samples given
    long long sampleBegin = 0, sampleEnd = 0;  // [begin, end): "A-B" is A .. B inclusive
};

// A whole non-negative decimal number up to `limit`, or -1.
long long parseCount(const std::string& text, long long limit)
{
    if (text.empty() || text.size() > 12 || text.find_first_not_of("0123456789") != std::string::npos)
        return -1;
    const long long v = std::stoll(text);
    return v <= limit ? v : -1;
}

void parseSplitArgs(SplitArgs& a)
{
    if (!a.tile.empty()) {
        const size_t slash = a.tile.find('/');
        const long long i = slash == std::string::npos ? -1 : parseCount(a.tile.substr(0, slash), 1 << 20);
        const long long n = slash == std::string::npos ? -1 : parseCount(a.tile.substr(slash + 1), 1 << 20);
        if (i < 1 || n < 1 || i > n)
            throw InputError("--tile: want I/N, tile I of N with 1 <= I <= N (N up to 1048576), got '" + a.tile + "'");
        a.tileIndex = int(i), a.tileCount = int(n);
    }
    if (!a.samples.empty()) {
        const size_t dash = a.samples.find('-');
        const long long first = dash == std::string::npos ? -1 : parseCount(a.samples.substr(0, dash), 0x7ffffffe);
        const long long last = dash == std::string::npos ? -1 : parseCount(a.samples.substr(dash + 1), 0x7ffffffe);
        if (first < 0 || last < first)
            throw InputError("--samples: want A-B, the samples A to B (both included, counted from 0) of the "
                             "seed's sequence, 0 <= A <= B < 2147483647, got '" + a.samples + "'");
        a.split = true;
        a.sampleBegin = first, a.sampleEnd = last + 1;
    }
}

// --frame, --frames, --skip-missing (docs/sequences.md).
struct SequenceArgs {
    int frame = 1;
    std::string frames;
    bool frameSet = false, framesSet = false;
    bool skipMissing = false;
};

// The first file of the sequence this frame lacks: a path written with a frame token (in the
// template) whose frame's file does not exist, as "<key>: '<path>'"; "" when none is missing.
// Files without tokens are not the sequence's: the loaders report those as ever.
std::string missingFrameFile(const Scene& templ, const Scene& frame)
{
    namespace fs = std::filesystem;
    std::error_code ec;
    const std::string sceneDir =
        templ.sourcePath.empty() ? std::string() : fs::path(templ.sourcePath).parent_path().string();
    for (size_t i = 0; i < templ.volumes.size(); ++i) {
        if (templ.volumes[i].source.type != SourceType::Vdb || !hasFrameTokens(templ.volumes[i].source.file))
            continue;
        const std::string path = resolveVdbPath(frame.volumes[i].source.file, sceneDir);
        if (!fs::exists(path, ec))
            return "volumes[" + std::to_string(i) + "].source.file: '" + path + "'";
    }
    for (size_t i = 0; i < templ.geometry.size(); ++i)
        if (templ.geometry[i].type == GeometryType::Mesh && hasFrameTokens(templ.geometry[i].file) &&
            !fs::exists(frame.geometry[i].file, ec))
            return "geometry[" + std::to_string(i) + "].file: '" + frame.geometry[i].file + "'";
    if (hasFrameTokens(templ.camera.holdoutDepth.file) && !fs::exists(frame.camera.holdoutDepth.file, ec))
        return "camera.holdout_depth.file: '" + frame.camera.holdoutDepth.file + "'";
    return "";
}

std::vector<int> framesToRender(const Scene& templ, const SequenceArgs& seq)
{
    if (seq.framesSet) {
        try {
            return parseFrameList(seq.frames);
        } catch (const InputError& e) {
            throw InputError(std::string("--frames: ") + e.what());
        }
    }
    return {seq.frameSet ? seq.frame : templ.render.frame};
}

// Renders one frame of the (already checked) scene and writes its outputs. Returns the render's
// seconds.
double renderFrame(const Scene& scene, bool explain, bool quiet, const PathtraceArgs& pt, const SplitArgs& split,
                   VolumeCache& cache, ShadowMapCache& shadowMaps, const std::string& label)
{
    const bool checkpoints = pt.checkpointSeconds > 0;
    Progress progress(label, 1000, ProgressOptions{quiet, {}, scene.render.frame});
    float last = 0.0f;
    RenderOptions options;
    options.outputAovsOnly = true;  // selectAovs below keeps no others
    options.progress = [&](float fraction) {
        size_t now = size_t(fraction * 1000.0f), before = size_t(last * 1000.0f);
        last = std::max(last, fraction);
        if (now > before)
            progress.advance(now - before);
        return true;
    };
    options.pathtrace.device = pt.device;
    options.volumeCache = &cache;
    options.shadowMapCache = &shadowMaps;
    options.tileIndex = split.tileIndex;
    options.tileCount = split.tileCount;
    if (split.split) {
        options.pathtrace.sampleBegin = split.sampleBegin;
        options.pathtrace.sampleEnd = split.sampleEnd;
    }
    // A checkpoint holds the running estimate (to resume), a sample split too (to merge).
    options.pathtrace.keepState = checkpoints || split.split;
    const std::string checkpointFile = checkpointPath(scene.output.file);
    std::optional<ResumePoint> resumed;
    if (pt.resume) {
        resumed = loadCheckpoint(scene, checkpointFile, {split.tileIndex, split.tileCount, split.split, split.sampleBegin});
        if (resumed) {
            options.pathtrace.resumeFrom = &resumed->film;
            options.pathtrace.resumeSamples = resumed->samples;
            options.pathtrace.resumeSeconds = resumed->seconds;
            if (!quiet)
                std::fprintf(stderr, "nimbus: resuming from %s at %lld samples per pixel\n", checkpointFile.c_str(),
                             resumed->samples);
        } else if (!quiet)
            std::fprintf(stderr, "nimbus: no checkpoint %s: rendering from the start\n", checkpointFile.c_str());
    }
    if (checkpoints) {
        // The running estimate, written atomically under a name that says so, its header with
        // nimbus:complete 0 and the spp reached (the engine adds those). The final name is written
        // only when the render finishes, so a killed render leaves nothing there that looks
        // finished; the last checkpoint stays. The film holds the output AOVs only
        // (outputAovsOnly), and their order is the file's own (OpenEXR sorts channels).
        options.pathtrace.checkpointSeconds = pt.checkpointSeconds;
        options.pathtrace.onCheckpoint = [&checkpointFile, quiet](const Film& film) {
            writeExr(film, checkpointFile);
            if (!quiet)
                std::fprintf(stderr, "nimbus: checkpoint written to %s\n", checkpointFile.c_str());
        };
    }
    RenderResult result = render(scene, options);
    progress.finish();
    if (explain)
        std::cout << result.plan.describe() << result.stats.describe(result.plan);
    // The running estimate stays in a sample split's EXR (merge pools it), in no other.
    std::vector<Aov> state, others;
    for (Aov& aov : result.film.aovs)
        (isStateAov(aov.name) ? state : others).push_back(std::move(aov));
    result.film.aovs = std::move(others);
    selectAovs(scene, result.film);
    if (split.split)
        for (Aov& aov : state)
            result.film.aovs.push_back(std::move(aov));
    writeOutputs(scene, result.film);
    if (checkpoints || resumed)
        std::remove(checkpointFile.c_str());  // the frame is complete; its checkpoint is stale
    return result.seconds;
}

int runRender(const SceneArgs& args, const OutputArgs& out, bool explain, bool quiet, const PathtraceArgs& pt,
              const SequenceArgs& seq, SplitArgs split)
{
    parseSplitArgs(split);
    if (out.outputSet && out.output.empty())
        throw InputError("-o: empty output path");
    Scene templ = loadScene(args);
    if (out.outputSet)
        templ.output.file = out.output;
    if (out.previewSet)
        templ.output.preview = out.preview;  // "": no preview
    const std::vector<int> frames = framesToRender(templ, seq);
    const std::string where = templ.sourcePath.empty() ? std::string() : templ.sourcePath + ": ";
    if (frames.size() > 1) {
        // Frames must not overwrite each other: each output path needs a token.
        auto needsToken = [&](const std::string& key, const std::string& path) {
            if (!path.empty() && !hasFrameTokens(path))
                throw InputError(where + key + ": '" + path + "' has no frame token ($F, $F4, ####): the " +
                                 std::to_string(frames.size()) + " frames of --frames would overwrite each other");
        };
        needsToken("output.file", templ.output.file);
        needsToken("output.preview", templ.output.preview);
        needsToken("output.deep", templ.output.deep);
    }
    // A tile's deep file would hold its band only, and nothing joins the bands (nimbus merge
    // reads flat files): refused rather than written half.
    if (split.tileCount > 0 && !templ.output.deep.empty())
        throw InputError(where + "output.deep: not written by a tile render (--tile " + std::to_string(split.tileIndex) +
                         "/" + std::to_string(split.tileCount) + "); render the frame whole for deep output");
    // Every frame is checked before the first renders: a bad output path or a missing frame file
    // stops the sequence before anything is written.
    const bool checkpoints = pt.checkpointSeconds > 0;
    std::vector<Scene> scenes;
    std::vector<std::string> missing;
    if (!isProgressive(templ.render.method)) {
        if (split.split)
            throw InputError("--samples: only the path tracer splits a frame's samples (method " +
                             std::string(methodName(templ.render.method)) + " splits it into tiles: --tile I/N)");
        if (pt.resume)
            throw InputError(std::string("--resume: only the path tracer writes checkpoints (method ") +
                             methodName(templ.render.method) + ")");
    }
    for (int frame : frames) {
        Scene scene = sceneAtFrame(templ, frame);
        validateScene(scene);
        checkOutputs(scene, checkpoints || pt.resume);
        if (split.tileCount > 0) {  // the tile has rows: checked on the film's header alone
            const Camera& c = scene.camera;
            Film window;
            window.height = c.height;
            window.y0 = std::max(0, int(std::floor(c.crop[2] * c.height)));
            window.y1 = std::min(c.height, int(std::ceil(c.crop[3] * c.height)));
            applyTile(window, split.tileIndex, split.tileCount);
        }
        std::string lacks = missingFrameFile(templ, scene);
        if (!lacks.empty() && !seq.skipMissing)
            throw InputError(where + lacks + ": no such file (frame " + std::to_string(frame) +
                             " of the sequence; --skip-missing renders the frames that have their files)");
        scenes.push_back(std::move(scene));
        missing.push_back(std::move(lacks));
    }

    VolumeCache cache;
    ShadowMapCache shadowMaps;
    const auto start = std::chrono::steady_clock::now();
    size_t rendered = 0, skipped = 0;
    for (size_t k = 0; k < frames.size(); ++k) {
        const std::string name = "frame " + std::to_string(frames[k]);
        if (!missing[k].empty()) {
            std::fprintf(stderr, "nimbus: warning: %s skipped, no output: %s%s: no such file\n", name.c_str(),
                         where.c_str(), missing[k].c_str());
            ++skipped;
            continue;
        }
        const double seconds =
            renderFrame(scenes[k], explain, quiet, pt, split, cache, shadowMaps, frames.size() > 1 ? name : std::string("render"));
        ++rendered;
        if (quiet)
            continue;
        const Scene& scene = scenes[k];
        std::fprintf(stderr, "nimbus: %s%swrote %s", frames.size() > 1 ? name.c_str() : "",
                     frames.size() > 1 ? ": " : "", scene.output.file.c_str());
        if (!scene.output.preview.empty())
            std::fprintf(stderr, " and %s", scene.output.preview.c_str());
        if (!scene.output.deep.empty())
            std::fprintf(stderr, " and %s", scene.output.deep.c_str());
        std::fprintf(stderr, " (%s, %.2f s", methodName(scene.render.method), seconds);
        if (frames.size() > 1)  // the per-frame line: what the sequence kept from the frame before
        {
            std::fprintf(stderr, "; volumes: %zu reused, %zu built; shadow maps: %zu reused, %zu built", cache.reused,
                         cache.built, shadowMaps.reused, shadowMaps.built);
            if (shadowMaps.skyReused + shadowMaps.skyBuilt > 0)
                std::fprintf(stderr, "; sky grids: %zu reused, %zu built", shadowMaps.skyReused, shadowMaps.skyBuilt);
        }
        std::fprintf(stderr, ")\n");
    }
    if (frames.size() > 1 && !quiet) {
        const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::fprintf(stderr, "nimbus: %zu frame(s) rendered in %.2f s, %zu skipped\n", rendered, total, skipped);
    }
    return kOk;
}

struct FarmArgs {
    std::string frames, output, nimbus;
    FarmPlanOptions options;
};

// The shot's job description (docs/farm.md), for `farm plan` and `farm submit`.
nlohmann::json buildFarmPlan(const SceneArgs& args, FarmArgs farm)
{
    Scene templ = loadScene(args);
    if (!farm.output.empty())
        templ.output.file = farm.output;
    if (farm.frames.empty())
        farm.options.frames = {templ.render.frame};
    else {
        try {
            farm.options.frames = parseFrameList(farm.frames);
        } catch (const InputError& e) {
            throw InputError(std::string("--frames: ") + e.what());
        }
    }
    namespace fs = std::filesystem;
    std::error_code ec;
    farm.options.cwd = fs::current_path(ec).string();
    farm.options.nimbus = farm.nimbus.empty() ? fs::read_symlink("/proc/self/exe", ec).string() : farm.nimbus;
    if (farm.options.nimbus.empty())
        farm.options.nimbus = "nimbus";
    // The commands name the scene as this one was named, absolutely: they may run anywhere.
    std::vector<std::string>& s = farm.options.sceneArgs;
    if (args.useDefault)
        s.push_back("--default");
    else
        s.push_back(fs::absolute(args.file, ec).string());
    for (const std::string& set : args.sets)
        s.insert(s.end(), {"--set", set});
    if (!args.method.empty())
        s.insert(s.end(), {"--method", args.method});
    return planFarm(templ, farm.options);
}

// `nimbus farm plan`: the shot's tasks as engine-neutral JSON on stdout (docs/farm.md).
int runFarmPlan(const SceneArgs& args, const FarmArgs& farm)
{
    std::cout << buildFarmPlan(args, farm).dump(2) << "\n";
    return kOk;
}

// `nimbus farm submit --engine slurm`: the plan as Slurm job arrays (docs/farm.md, "Slurm"); the
// job ids on stdout ("render <id>", "merge <id>"), what was written on stderr.
int runFarmSubmit(const SceneArgs& args, const FarmArgs& farm, const std::string& engine, const SlurmOptions& slurm,
                  bool quiet)
{
    if (engine != "slurm")
        throw InputError("farm submit: --engine '" + engine +
                         "': nimbus submits to slurm; other farm managers read `nimbus farm plan` (docs/farm.md)");
    const SlurmSubmission s = submitSlurm(buildFarmPlan(args, farm), slurm);
    if (slurm.dryRun) {
        if (!quiet)
            std::fprintf(stderr,
                         "nimbus: farm submit: dry run: wrote render.sbatch%s, submit.sh and plan.json in %s (%zu "
                         "render, %zu merge task(s)); nothing submitted\n",
                         s.mergeScript.empty() ? "" : ", merge.sbatch", s.jobDir.c_str(), s.renderTasks, s.mergeTasks);
        return kOk;
    }
    std::cout << "render " << s.renderJobId << "\n";
    if (!s.mergeJobId.empty())
        std::cout << "merge " << s.mergeJobId << "\n";
    std::cout.flush();
    if (!quiet) {
        std::fprintf(stderr, "nimbus: farm submit: render array %s (%zu task(s))", s.renderJobId.c_str(), s.renderTasks);
        if (!s.mergeJobId.empty())
            std::fprintf(stderr, ", merge array %s (%zu task(s), afterok:%s)", s.mergeJobId.c_str(), s.mergeTasks,
                         s.renderJobId.c_str());
        std::fprintf(stderr, "; scripts and logs in %s\n", s.jobDir.c_str());
    }
    return kOk;
}

int runInfo(const SceneArgs& args)
{
    Scene scene = loadScene(args);
    validateScene(scene);
    const Camera& c = scene.camera;
    std::cout << "scene " << (scene.sourcePath.empty() ? "(default)" : scene.sourcePath) << "\n";
    std::cout << "  camera: " << c.width << "x" << c.height << ", fov " << c.fov << " deg"
              << (c.hasMotion ? ", motion blur" : "");
    // The camera alone at the frame (the volumes and geometry are planRender's, which warns).
    Scene cameraAtFrame;
    cameraAtFrame.camera = c;
    cameraAtFrame.render = scene.render;
    evaluateAnimation(cameraAtFrame);
    const Keys<float>& zoom = cameraAtFrame.camera.fovShutterMotion;
    if (!zoom.frames.empty())
        std::cout << "; fov moves within the shutter (" << zoom.frames.size() << " knots, " << zoom.values.front()
                  << " to " << zoom.values.back() << " deg)";
    std::cout << "\n";
    std::cout << "  " << scene.lights.size() << " light(s), " << scene.volumes.size() << " volume(s), method "
              << methodName(scene.render.method) << ", spp ";
    if (scene.render.spp > 0)
        std::cout << scene.render.spp;
    else if (!isProgressive(scene.render.method))
        std::cout << kDefaultMarchSpp;
    else
        std::cout << "until relMSE " << scene.render.noiseTarget;
    std::cout << ", seed " << scene.render.seed << "\n";
    std::cout << planRender(scene).describe();
    return kOk;
}

}  // namespace

int main(int argc, char** argv)
{
    // Ctrl-C or a farm's SIGTERM during a write leaves no temporary file behind (TempFiles.h).
    removeTempFilesOnSignals();
    CLI::App app{"nimbus: a volume renderer (single scattering, WKB multiple scattering, path tracing)"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("nimbus ") + NIMBUS_VERSION);

    SceneArgs renderArgs, infoArgs;
    OutputArgs outputArgs;
    bool explain = false, quiet = false;
    CLI::App* render = app.add_subcommand("render", "Render a scene to EXR (and a preview PNG)");
    addSceneArgs(render, renderArgs);
    addPreviewArgs(render, renderArgs);
    CLI::Option* outputOption =
        render->add_option("-o,--output", outputArgs.output, "EXR output path (overrides output.file)");
    CLI::Option* previewOption =
        render->add_option("--preview", outputArgs.preview, "Preview PNG path (overrides output.preview; \"\": none)");
    render->add_flag("--explain", explain, "Print the render plan, then the render statistics (stage times, memory)");
    render->add_flag("-q,--quiet", quiet, "No progress or info lines");
    PathtraceArgs ptArgs;
    render->add_option("--device", ptArgs.device,
                       "pathtrace: OpenCL device index or name substring (see `nimbus devices`)");
    // NaN passed CLI11's PositiveNumber, and -1 was answered with a 309-digit bound.
    render->add_option("--checkpoint", ptArgs.checkpointSeconds, "pathtrace: write the running estimate every SECONDS")
        ->check(CLI::Validator(
            [](std::string& text) -> std::string {
                char* end = nullptr;
                const double v = std::strtod(text.c_str(), &end);
                if (end == text.c_str() || *end != '\0' || !std::isfinite(v) || v <= 0.0)
                    return "must be a positive, finite number of seconds, got '" + text + "'";
                return "";
            },
            "SECONDS"));
    SequenceArgs seqArgs;
    CLI::Option* frameOption =
        render->add_option("--frame", seqArgs.frame, "Render frame N (render.frame): the frame tokens $F, $F4, #### of paths");
    CLI::Option* framesOption = render->add_option(
        "--frames", seqArgs.frames, "Render the frames in one process: 1-240, 1-240x2 (every 2nd), 1,5,9-12");
    frameOption->excludes(framesOption);
    render->add_flag("--skip-missing", seqArgs.skipMissing,
                     "A frame whose sequence file is missing: a warning and no output, not an error");

    render->add_flag("--resume", ptArgs.resume,
                     "pathtrace: continue from the checkpoint <name>.partial.exr if there is one (docs/farm.md)");
    SplitArgs splitArgs;
    render->add_option("--tile", splitArgs.tile,
                       "Render tile I of N (horizontal bands of the data window, 1 <= I <= N); merge with `nimbus merge`");
    render->add_option("--samples", splitArgs.samples,
                       "pathtrace: render the samples A to B (included, from 0) of the seed's sequence; merge with "
                       "`nimbus merge`");

    std::string mergeOutput;
    std::vector<std::string> partFiles;
    CLI::App* merge = app.add_subcommand(
        "merge", "Merge the tiles and sample splits of a frame (from --tile, --samples) into OUT.exr");
    merge->add_option("output", mergeOutput, "The merged EXR")->required();
    merge->add_option("parts", partFiles, "The parts' EXRs")->required();
    merge->add_flag("-q,--quiet", quiet, "No info line");

    SceneArgs farmArgs;
    FarmArgs farmOptions;
    std::string farmEngine;
    SlurmOptions slurmOptions;
    CLI::App* farm = app.add_subcommand("farm", "Render farms: the job description of a shot, Slurm (docs/farm.md)");
    farm->require_subcommand(1);
    CLI::App* farmPlan =
        farm->add_subcommand("plan", "Print the shot's tasks (renders, merges, dependencies) as engine-neutral JSON");
    CLI::App* farmSubmit =
        farm->add_subcommand("submit", "Submit the shot to a farm: Slurm job arrays (renders, then merges afterok)");
    for (CLI::App* sub : {farmPlan, farmSubmit}) {
        addSceneArgs(sub, farmArgs);
        sub->add_option("--frames", farmOptions.frames, "Frames: 1-240, 1-240x2, 1,5,9-12 (default render.frame)");
        sub->add_option("-o,--output", farmOptions.output, "EXR output path of each frame (overrides output.file)");
        sub->add_option("--tiles", farmOptions.options.tiles, "Tiles per frame (--tile I/N), merged by a merge task")
            ->check(CLI::Range(1, 1 << 20));
        sub->add_option("--sample-splits", farmOptions.options.sampleSplits,
                        "pathtrace: sample splits per tile (--samples A-B of render.spp), merged by a merge task")
            ->check(CLI::Range(1, 1 << 20));
        sub->add_option("--checkpoint", farmOptions.options.checkpointSeconds,
                        "pathtrace: the tasks' checkpoint interval in seconds (default 60)")
            ->check(CLI::Range(1e-3, 1e9));
        sub->add_option("--retries", farmOptions.options.retries, "How often a failed task may be rerun (default 2)")
            ->check(CLI::Range(0, 1000));
        sub->add_option("--nimbus", farmOptions.nimbus, "The nimbus binary the tasks run (default this one)");
    }
    farmSubmit->add_option("--engine", farmEngine, "The farm manager: slurm")->required();
    farmSubmit->add_option("--job-dir", slurmOptions.jobDir,
                           "Folder for the job's scripts and logs, absent or empty (default ./nimbus-farm/<scene>.<time>)");
    farmSubmit->add_flag("--dry-run", slurmOptions.dryRun, "Write the scripts into the job folder, submit nothing");
    farmSubmit->add_option("--sbatch-arg", slurmOptions.sbatchArgs,
                           "An sbatch option for both arrays, e.g. --sbatch-arg=--partition=render (repeatable)")
        ->allow_extra_args(false);
    farmSubmit->add_option("--job-name", slurmOptions.jobName, "The arrays' name prefix (default nimbus)");
    farmSubmit->add_flag("-q,--quiet", quiet, "No info line (the job ids still go to stdout)");

    CLI::App* devices = app.add_subcommand("devices", "List the OpenCL devices the path tracer can use");

    CLI::App* info = app.add_subcommand("info", "Print the scene summary and the render plan");
    addSceneArgs(info, infoArgs);

    SceneArgs compareArgs;
    CompareOptions compareOptions;
    CLI::App* compare =
        app.add_subcommand("compare", "Error against run time: WKB and the path tracer against a converged reference");
    addSceneArgs(compare, compareArgs);
    compare->add_option("--out", compareOptions.outDir,
                        "Output directory (compare.csv, summary.md, panels/, error_vs_time.png, sheet.png)");
    compare
        ->add_option("--minutes", compareOptions.minutes,
                     "Scales the reference's 45 s and the path tracer's 0.5..8 s ladder")
        ->check(CLI::PositiveNumber);
    compare
        ->add_option("--reference-minutes", compareOptions.referenceMinutes,
                     "Scales the reference's 45 s alone (default: --minutes); a longer reference lowers the floor")
        ->check(CLI::PositiveNumber);
    compare->add_option("--seeds", compareOptions.seeds, "Independent path-tracer seeds per ladder step")
        ->check(CLI::Range(1, 64));
    compare->add_option("--cache", compareOptions.cacheDir, "Reference cache directory");
    compare->add_flag("--full", compareOptions.fullLadder, "A longer WKB quality ladder");
    compare->add_flag("-q,--quiet", quiet, "No progress lines");

    CLI::App* dump = app.add_subcommand("default-scene", "Print the embedded default scene as JSON");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e) == 0 ? kOk : kBadInput;
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e) == 0 ? kOk : kBadInput;
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e) == 0 ? kOk : kBadInput;
    } catch (const CLI::ParseError& e) {
        // One line, as every other bad input (CLI11 would add "Run with --help ...").
        std::fprintf(stderr, "nimbus: error: %s\n", oneLine(e.what()).c_str());
        return kBadInput;
    }

    try {
        setLogQuiet(quiet);
        if (quiet)
            Progress::setQuiet(true);
        if (*render) {
            outputArgs.outputSet = outputOption->count() > 0;
            outputArgs.previewSet = previewOption->count() > 0;
            seqArgs.frameSet = frameOption->count() > 0;
            seqArgs.framesSet = framesOption->count() > 0;
            return runRender(renderArgs, outputArgs, explain, quiet, ptArgs, seqArgs, splitArgs);
        }
        if (*farmPlan)
            return runFarmPlan(farmArgs, farmOptions);
        if (*farmSubmit)
            return runFarmSubmit(farmArgs, farmOptions, farmEngine, slurmOptions, quiet);
        if (*merge) {
            const MergeSummary m = mergeParts(mergeOutput, partFiles);
            if (!quiet)
                std::fprintf(stderr, "nimbus: merged %d part(s) (%d tile(s), %d per tile; %lld spp) into %s\n", m.parts,
                             m.tiles, m.splitsPerTile, m.spp, mergeOutput.c_str());
            return kOk;
        }
        if (*devices) {
            std::vector<std::string> list = listOpenClDevices();
            for (const std::string& device : list)  // "index: name [...]"
                std::cout << device << "\n";
            if (list.empty())
                std::cout << "(no OpenCL device found)\n";
            return kOk;
        }
        if (*info)
            return runInfo(infoArgs);
        if (*compare) {
            compareOptions.quiet = quiet;
            Scene scene = loadScene(compareArgs);
            validateScene(scene);
            const CompareResult result = runCompare(scene, compareOptions);
            if (!result.chartsError.empty()) {
                std::fprintf(stderr, "nimbus: error: compare: the charts were not drawn: %s; compare.csv, "
                                     "summary.md and panels/ are in %s\n",
                             result.chartsError.c_str(), compareOptions.outDir.c_str());
                return kRenderFailure;
            }
            return kOk;
        }
        if (*dump) {
            std::cout << sceneToJson(defaultScene()).dump(2) << "\n";
            return kOk;
        }
    } catch (const InputError& e) {
        std::fprintf(stderr, "nimbus: error: %s\n", oneLine(e.what()).c_str());
        return kBadInput;
    } catch (const Cancelled& e) {
        std::fprintf(stderr, "nimbus: %s\n", oneLine(e.what()).c_str());
        return kRenderFailure;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: render failed: %s\n", oneLine(e.what()).c_str());
        return kRenderFailure;
    }
    return kOk;
}
