#include "Renderer.h"

#include "../render/ShadowMapCache.h"

#include "IntegratorRegistry.h"
#include "MemoryEstimate.h"
#include "TileDriver.h"

#include "../render/FilmLayout.h"
#include "../render/RenderPlanner.h"
#include "../scene/CameraMatrices.h"
#include "../scene/FrameTokens.h"
#include "../scene/SceneJson.h"
#include "../scene/SceneValidate.h"

#include "../core/Error.h"
#include "../core/Log.h"

#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_reduce.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <sys/resource.h>
#include <variant>

namespace nimbus {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Non-finite samples never reach the film silently (issue 18, failure 3): every NaN or infinite
// value an integrator left is set to 0, counted, and reported in one warning naming the AOVs.
// Within the extinction range (SceneValidate.h) a render has none; this is the net under
// whatever still overflows (a light of 1e38 W/m^2, say).
void zeroNonFinite(Film& film)
{
    size_t total = 0;
    std::string names;
    for (Aov& aov : film.aovs) {
        float* p = aov.pixels.data();
        const size_t count = tbb::parallel_reduce(
            tbb::blocked_range<size_t>(0, aov.pixels.size(), size_t(1) << 16), size_t(0),
            [&](const tbb::blocked_range<size_t>& r, size_t n) {
                for (size_t i = r.begin(); i != r.end(); ++i)
                    if (!std::isfinite(p[i]))
                        p[i] = 0.0f, ++n;
                return n;
            },
            [](size_t a, size_t b) { return a + b; });
        if (count) {
            total += count;
            names += (names.empty() ? "" : ", ") + aov.name + " (" + std::to_string(count) + ")";
        }
    }
    if (total)
        logWarning("render: " + std::to_string(total) + " non-finite pixel values (NaN or inf) set to 0 in " + names);
}

std::string settingsSummary(const Scene& s)
{
    std::ostringstream o;
    o << "spp=" << s.render.spp << " step=" << s.render.step
      << " shadow_map_resolution=" << s.render.shadowMapResolution << " tolerance=" << s.render.tolerance
      << " shadow_step=" << s.render.shadowStep << " light_samples=" << s.render.lightSamples;
    return o.str();
}

// Bytes: the most this process has held resident so far (Linux reports KiB).
double peakResidentBytes()
{
    struct rusage usage;
    return ::getrusage(RUSAGE_SELF, &usage) == 0 ? double(usage.ru_maxrss) * 1024.0 : 0.0;
}

// Samples per pixel the film holds: the path tracer's count so far, else the march's.
int sppReached(const Film& film, const Scene& scene)
{
    if (const FilmValue* v = film.meta("pathtrace_spp"))
        if (const std::string* text = std::get_if<std::string>(v))
            return std::atoi(text->c_str());
    if (isProgressive(scene.render.method))
        return 0;
    return scene.render.spp > 0 ? scene.render.spp : kDefaultMarchSpp;
}

// Scenes built in code reach render() without the JSON loader: give unnamed lights their index
// as a name (as the loader does) and run the same checks. Paths are the frame's (FrameTokens.h).
Scene checkedScene(const Scene& scene)
{
    Scene named = sceneAtFrame(scene, scene.render.frame);
    applyDefaultNames(named);
    validateScene(named);
    return named;
}

struct Planned {
    std::unique_ptr<RenderContext> context;
    RenderPlan plan;
};

// The planning pass: the volumes loaded (the one heavy step a plan cannot do without: the
// optical depths and brick counts it reports are the loaded grids'), the shared plan, the
// integrator's own part. Nothing is built for rendering yet.
// kernelBvh: build the path tracer's tree of the geometry too (method pathtrace, which then reuses
// it, and `nimbus info`, which reports it).
// cancel: the caller's flag, polled inside the volumes' load and between the steps here.
Planned planPass(const Scene& scene, const IntegratorEntry& entry, RenderStats& stats, VolumeCache* cache = nullptr,
                 bool kernelBvh = false, const std::atomic<bool>* cancel = nullptr)
{
    StopFlag stop;
    stop.watch(cancel);
    auto t = std::chrono::steady_clock::now();
    VolumeSet volumes(buildVolumes(scene, cache, &stop), scene.render.step);
    throwIfStopped(&stop);
    setShutterOf(volumes, scene);
    stats.addStage("volumes", secondsSince(t));
    Planned p;
    p.plan = planScene(scene, volumes);
    p.plan.aovs = aovNames(scene, entry.traits);
    t = std::chrono::steady_clock::now();
    p.context = RenderContext::create(scene, std::move(volumes), p.plan);
    if (p.context->geometry && kernelBvh)
        p.context->kernelBvh = std::make_shared<const KernelBvh>(buildKernelBvh(p.context->geometry->geometry()));
    throwIfStopped(&stop);  // meshes read and their trees built
    if (p.context->geometry || p.context->holdoutDepth) {
        stats.addStage("geometry", secondsSince(t));  // meshes read, BVHs built, depth map read
        planGeometry(*p.context, p.plan);
    }
    if (entry.plan)
        entry.plan(*p.context, p.plan);
    // Everything above is resident now; what follows is estimated before it is allocated.
    p.plan.memory = estimateMemory(scene, *p.context, p.plan);
    return p;
}

}  // namespace

void addFrameMetadata(Film& film, const Scene& scene, double seconds, bool complete)
{
    film.set("version", NIMBUS_VERSION);
    film.set("method", methodName(scene.render.method));
    film.set("seed", std::to_string(scene.render.seed));
    film.set("frame", scene.render.frame);
    film.set("render_time", std::to_string(seconds));
    film.set("settings", settingsSummary(scene));
    film.set("scene", sceneToJson(scene).dump());
    if (!scene.sourcePath.empty())
        film.set("scene_file", scene.sourcePath);
    const int spp = sppReached(film, scene);
    const int x0 = film.x0, x1 = film.x1 > 0 ? film.x1 : film.width;
    const int y0 = film.y0, y1 = film.y1 > 0 ? film.y1 : film.height;
    film.set("complete", complete ? 1 : 0);
    film.set("spp", spp);
    film.set("samples", double(spp) * double(x1 - x0) * double(y1 - y0));
    film.set("memory_peak_bytes", peakResidentBytes());
    film.set("worldToCamera", worldToCameraMatrix(scene.camera));
    film.set("worldToNDC", worldToNdcMatrix(scene.camera));
}

void applyTile(Film& film, int index, int count)
{
    if (count == 0 && index == 0)
        return;
    if (count < 1 || index < 1 || index > count)
        throw InputError("--tile " + std::to_string(index) + "/" + std::to_string(count) +
                         ": want I/N with 1 <= I <= N");
    const long long h = film.y1 - film.y0;
    if (count > h)
        throw InputError("--tile " + std::to_string(index) + "/" + std::to_string(count) + ": the data window has " +
                         std::to_string(h) + " rows, fewer than " + std::to_string(count) + " tiles");
    const int y0 = film.y0;
    film.y0 = y0 + int((index - 1) * h / count);
    film.y1 = y0 + int(index * h / count);
}

std::vector<std::string> aovNames(const Scene& scene, Method method)
{
    return aovNames(scene, integratorEntry(method).traits);
}

void setupFilm(Film& film, const Scene& scene, Method method, bool outputAovsOnly)
{
    setupFilm(film, scene, integratorEntry(method).traits, outputAovsOnly);
}

RenderPlan planRender(const Scene& input)
{
    const Scene scene = checkedScene(input);
    RenderStats stats;
    return planPass(scene, integratorEntry(scene.render.method), stats, nullptr, true).plan;
}

RenderResult render(const Scene& input, const RenderOptions& callerOptions)
{
    const Scene scene = checkedScene(input);
    auto start = std::chrono::steady_clock::now();
    // A checkpoint carries the header a frame does, marked incomplete with the samples so far.
    RenderOptions options = callerOptions;
    if (callerOptions.pathtrace.onCheckpoint)
        options.pathtrace.onCheckpoint = [&](const Film& running) {
            Film checkpoint = running;
            addFrameMetadata(checkpoint, scene, secondsSince(start), false);
            if (callerOptions.tileCount > 0)
                checkpoint.set("tile", std::to_string(callerOptions.tileIndex) + "/" +
                                           std::to_string(callerOptions.tileCount));
            callerOptions.pathtrace.onCheckpoint(checkpoint);
        };
    std::unique_ptr<tbb::global_control> threads;
    if (scene.render.threads > 0)
        threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                        size_t(scene.render.threads));
    const IntegratorEntry& entry = integratorEntry(scene.render.method);
    RenderResult result;
    Planned planned =
        planPass(scene, entry, result.stats, options.volumeCache, scene.render.method == Method::Pathtrace, options.cancel);
    // Memory known before it is spent (issue 18, item 4): nothing large is allocated before this.
    checkMemoryLimit(scene, planned.plan.memory);
    setupFilm(result.film, scene, entry.traits, options.outputAovsOnly);
    applyTile(result.film, options.tileIndex, options.tileCount);
    if (!scene.output.deep.empty()) {  // single and wkb (validateScene refuses pathtrace)
        auto deep = std::make_shared<DeepFilm>();
        deep->width = result.film.width, deep->height = result.film.height;
        deep->maxSamples = scene.output.deepSamples;
        deep->pixels.resize(size_t(deep->width) * size_t(deep->height));
        result.film.deep = std::move(deep);
    }
    const RenderPlan& plan = planned.plan;
    RenderContext& ctx = *planned.context;
    // Cancel (RenderControl.h): between the stages here, inside the tiles through ctx.stop.
    ctx.stop.watch(options.cancel);
    auto checkCancel = [&] {
        if (ctx.stop.raised())
            throw Cancelled();
    };
    checkCancel();
    if (entry.traits.shadowMaps) {
        if (options.shadowMapCache)
            options.shadowMapCache->reused = options.shadowMapCache->built = options.shadowMapCache->skyReused =
                options.shadowMapCache->skyBuilt = 0;
        ctx.buildShadowMaps(plan, result.stats, options.shadowMapCache);
    }
    checkCancel();
    std::unique_ptr<Integrator> integrator = entry.create(ctx, plan, options, result.stats);
    checkCancel();
    auto t = std::chrono::steady_clock::now();
    if (integrator->drive() == Integrator::Drive::CameraRays) {
        TileSampleCounts counts;
        renderTiles(ctx, *integrator, result.film, options, &counts);
        result.stats.addStage("march", secondsSince(t));
        result.stats.cameraSamples = counts.samples;
        result.stats.marchedPixels = counts.pixels;
        result.stats.pixelsAtMostSpp = counts.pixelsAtMost;
        result.stats.baseSpp = counts.baseSpp;
        result.stats.maxSpp = counts.maxSpp;
    } else {
        integrator->renderImage(result.film, options);
        result.stats.addStage(methodName(scene.render.method), secondsSince(t));
    }
    zeroNonFinite(result.film);
    if (options.shadowMapCache && entry.traits.shadowMaps)
        options.shadowMapCache->keep(ctx, ctx.skySettings());
    result.plan = planned.plan;

    result.seconds = secondsSince(start);
    addFrameMetadata(result.film, scene, result.seconds, true);
    result.film.set("memory_estimate_bytes", double(plan.memory.estimateBytes));  // beside memory_peak_bytes
    if (options.tileCount > 0)
        result.film.set("tile", std::to_string(options.tileIndex) + "/" + std::to_string(options.tileCount));
    return result;
}

}  // namespace nimbus
