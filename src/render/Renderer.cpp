#include "Renderer.h"

#include "../core/Error.h"
#include "../core/Log.h"
#include "../pathtracer/Pathtracer.h"
#include "../scene/KernelScene.h"
#include "../scene/SceneValidate.h"
#include "../wkb/WkbIntegrator.h"
#include "RenderContext.h"
#include "SingleScatter.h"
#include "TileCulling.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>

namespace nimbus {

namespace {

constexpr int kTile = 16;

std::string lightAov(const Light& l, size_t i) { return "light_" + (l.name.empty() ? std::to_string(i) : l.name); }

std::string settingsSummary(const Scene& s)
{
    std::ostringstream o;
    o << "spp=" << s.render.spp << " step=" << s.render.step << " shadow_map_resolution=" << s.render.shadowMapResolution
      << " tolerance=" << s.render.tolerance << " shadow_step=" << s.render.shadowStep
      << " light_samples=" << s.render.lightSamples;
    return o.str();
}

// The L0 + L1 (+ L2+) camera-ray integrators share this driver: tiles in parallel, each
// pixel's samples drawn from (seed, pixel, sample) so any thread count gives the same image.
// `wkb`, when given, adds L2+ to each camera sample after marchSingle, continuing its random
// stream, so that wkb's L0 and L1 are exactly single's.
void renderMarched(const RenderContext& ctx, Film& film, const RenderOptions& options,
                   const wkb::WkbIntegrator* wkb = nullptr)
{
    const Scene& scene = *ctx.scene;
    const NbCamera cam = makeNbCamera(scene.camera);
    const int spp = scene.render.spp > 0 ? scene.render.spp : kDefaultMarchSpp;
    const size_t nLights = ctx.lights.size();
    const int tilesX = (film.x1 - film.x0 + kTile - 1) / kTile, tilesY = (film.y1 - film.y0 + kTile - 1) / kTile;
    const int tileCount = std::max(0, tilesX * tilesY);
    std::atomic<int> done{0};
    std::atomic<bool> cancelled{false};

    Aov* beauty = film.find("beauty");
    Aov* L0 = film.find("L0");
    Aov* L1 = film.find("L1");
    Aov* L2 = film.find("L2plus");
    Aov* alpha = film.find("alpha");
    Aov* depth = film.find("depth");
    std::vector<Aov*> perLightAov(nLights, nullptr);
    for (size_t i = 0; i < nLights; ++i)
        perLightAov[i] = film.find(ctx.lights[i].aov);

    // One pixel's samples, summed: the radiance terms, the opacity-weighted depth and the
    // per-light L1.
    struct PixelSum {
        CameraSample sum;
        float depthSum = 0.0f, depthWeight = 0.0f;
        std::vector<float> perLight;
        void reset(size_t n)
        {
            sum = CameraSample();
            sum.transmittance = splat(0.0f);
            depthSum = depthWeight = 0.0f;
            perLight.assign(n, 0.0f);
        }
        void add(const CameraSample& cs, const float* light)
        {
            sum.L0 += cs.L0;
            sum.L1 += cs.L1;
            sum.L2plus += cs.L2plus;
            sum.transmittance += cs.transmittance;
            // Each sample's depth weighs by its opacity, summed step by step (SingleScatter.cpp:
            // 1 - T of a nearly clear ray is rounding).
            depthSum += cs.opacity * cs.depth;
            depthWeight += cs.opacity;
            for (size_t i = 0; i < perLight.size(); ++i)
                perLight[i] += light[i];
        }
    };
    const float inv = 1.0f / float(spp);
    auto store = [&](int x, int y, const PixelSum& px) {
        Rgb l0 = px.sum.L0 * inv, l1 = px.sum.L1 * inv, l2 = px.sum.L2plus * inv;
        Rgb b = l0 + l1 + l2;
        float a = 1.0f - nbAverage(px.sum.transmittance * inv);
        float* pb = film.pixel(*beauty, x, y);
        pb[0] = b.x, pb[1] = b.y, pb[2] = b.z, pb[3] = a;
        auto put3 = [&](Aov* aov, Rgb v) {
            if (!aov)
                return;
            float* p = film.pixel(*aov, x, y);
            p[0] = v.x, p[1] = v.y, p[2] = v.z;
        };
        put3(L0, l0);
        put3(L1, l1);
        put3(L2, l2);
        if (alpha)
            *film.pixel(*alpha, x, y) = a;
        if (depth)
            *film.pixel(*depth, x, y) = px.depthWeight > 0.0f ? px.depthSum / px.depthWeight : 0.0f;
        for (size_t i = 0; i < nLights; ++i)
            put3(perLightAov[i], make_float3(px.perLight[3 * i] * inv, px.perLight[3 * i + 1] * inv,
                                             px.perLight[3 * i + 2] * inv));
    };
    // What every sample of a pixel whose rays all miss the volumes gathers: the background
    // (marchSingle's answer to such a ray, summed the same way, so the pixels are identical).
    PixelSum background;
    background.reset(3 * nLights);
    {
        CameraSample miss;
        miss.L0 = ctx.background;
        const std::vector<float> none(3 * nLights, 0.0f);
        for (int s = 0; s < spp; ++s)
            background.add(miss, none.data());
    }

    // Tiles whose rays can meet an occupied brick of some volume (density or emission); the
    // others see only the background. Not with WKB, which keeps its own per-ray path.
    std::vector<char> seesBricks(size_t(tileCount), 1);
    if (!wkb) {
        std::fill(seesBricks.begin(), seesBricks.end(), 0);
        bool bounded = true;
        for (const auto& v : ctx.volumes.volumes()) {
            bounded = bounded && markTilesSeeingBricks(cam, film.width, film.height, film.x0, film.y0, kTile, tilesX,
                                                       tilesY, v->density, v->worldFromIndex, seesBricks);
            if (v->hasEmission())
                bounded = bounded && markTilesSeeingBricks(cam, film.width, film.height, film.x0, film.y0, kTile,
                                                           tilesX, tilesY, v->emission, v->worldFromIndex, seesBricks);
        }
        if (!bounded)
            std::fill(seesBricks.begin(), seesBricks.end(), 1);
    }

    const size_t perLightStride = 3 * nLights;
    tbb::parallel_for(tbb::blocked_range<int>(0, tileCount, 1), [&](const tbb::blocked_range<int>& r) {
        // One row of a tile at a time: every sample's ray first, then their marches together
        // (marchSingleRays takes eight at once where it can), then the pixels' sums.
        std::vector<float3> origins, directions;
        std::vector<NbRng> rngs;
        std::vector<CameraSample> samples;
        std::vector<float> perLight;
        PixelSum px;
        for (int tile = r.begin(); tile != r.end(); ++tile) {
            if (cancelled.load(std::memory_order_relaxed))
                return;
            const int tx0 = film.x0 + (tile % tilesX) * kTile, ty0 = film.y0 + (tile / tilesX) * kTile;
            const int tx1 = std::min(tx0 + kTile, film.x1), ty1 = std::min(ty0 + kTile, film.y1);
            // L2+ is not asked of such tiles: WKB keeps its own per-ray path.
            const bool empty = !wkb && (!seesBricks[size_t(tile)] || tileMissesBox(cam, film.width, film.height, tx0, ty0,
                                                                                   tx1, ty1, ctx.volumes.worldBounds()));
            for (int y = ty0; y < ty1; ++y) {
                if (empty) {
                    for (int x = tx0; x < tx1; ++x)
                        store(x, y, background);
                    continue;
                }
                const size_t rays = size_t(tx1 - tx0) * size_t(spp);
                origins.resize(rays), directions.resize(rays), rngs.resize(rays);
                samples.assign(rays, CameraSample());
                perLight.assign(rays * perLightStride, 0.0f);
                for (int x = tx0, i = 0; x < tx1; ++x) {
                    nb_uint pixelIndex = nb_uint(y) * nb_uint(film.width) + nb_uint(x);
                    for (int s = 0; s < spp; ++s, ++i) {
                        NbRng& rng = rngs[size_t(i)];
                        rng = nbRngStart(scene.render.seed, pixelIndex, nb_uint(s));
                        float jx = nbRngNext(&rng), jy = nbRngNext(&rng), time = nbRngNext(&rng);
                        nbCameraRay(cam, x + jx, y + jy, film.width, film.height, time, &origins[size_t(i)],
                                    &directions[size_t(i)]);
                    }
                }
                if (wkb) {
                    for (size_t i = 0; i < rays; ++i) {
                        float* pl = perLight.data() + perLightStride * i;
                        marchSingle(ctx, origins[i], directions[i], rngs[i], samples[i], pl);
                        wkb->march(origins[i], directions[i], rngs[i], samples[i], pl);
                    }
                } else {
                    marchSingleRays(ctx, int(rays), origins.data(), directions.data(), rngs.data(), samples.data(),
                                    perLight.data());
                }
                for (int x = tx0, i = 0; x < tx1; ++x) {
                    px.reset(3 * nLights);
                    for (int s = 0; s < spp; ++s, ++i)
                        px.add(samples[size_t(i)], perLight.data() + perLightStride * size_t(i));
                    store(x, y, px);
                }
            }
            int finished = ++done;
            bool keepGoing = true;
            if (options.progress)
                keepGoing = options.progress(float(finished) / float(tileCount));
            if (!keepGoing || (options.cancel && options.cancel->load()))
                cancelled = true;
        }
    });
    if (cancelled)
        throw Cancelled();
}

}  // namespace

void setupFilm(Film& film, const Scene& scene, Method method, bool outputAovsOnly)
{
    const Camera& c = scene.camera;
    film.width = c.width;
    film.height = c.height;
    film.x0 = std::max(0, int(std::floor(c.crop[0] * c.width)));
    film.x1 = std::min(c.width, int(std::ceil(c.crop[1] * c.width)));
    film.y0 = std::max(0, int(std::floor(c.crop[2] * c.height)));
    film.y1 = std::min(c.height, int(std::ceil(c.crop[3] * c.height)));
    // A plane is 1-4 floats per pixel, allocated and zeroed before the first ray: where only the
    // output's are wanted, no others (the beauty is always there: every integrator writes it).
    const auto& wanted = scene.output.aovs;
    for (const std::string& name : aovNames(scene, method)) {
        if (outputAovsOnly && name != "beauty" && !wanted.empty() &&
            std::find(wanted.begin(), wanted.end(), name) == wanted.end())
            continue;
        bool data = name == "alpha" || name == "depth" || name == "variance";
        film.add(name, name == "beauty" ? 4 : (data ? 1 : 3), data);
    }
}

std::vector<std::string> aovNames(const Scene& scene, Method method)
{
    std::vector<std::string> names = {"beauty", "L0", "L1"};
    if (method != Method::Single)
        names.push_back("L2plus");
    names.push_back("alpha");
    names.push_back("depth");
    if (method == Method::Pathtrace)
        names.push_back("variance");
    for (size_t i = 0; i < scene.lights.size(); ++i)
        names.push_back(lightAov(scene.lights[i], i));
    return names;
}

namespace {

// Scenes built in code reach render() without the JSON loader: give unnamed lights their index
// as a name (as the loader does) and run the same checks.
Scene checkedScene(const Scene& scene)
{
    Scene named = scene;
    applyDefaultNames(named);
    validateScene(named);
    return named;
}

RenderResult renderChecked(const Scene& scene, const RenderOptions& options);

}  // namespace

RenderPlan planRender(const Scene& input)
{
    const Scene scene = checkedScene(input);
    auto ctx = RenderContext::create(scene, false);
    if (scene.render.method == Method::Wkb)
        wkb::planWkb(*ctx, ctx->plan);
    return ctx->plan;
}

RenderResult render(const Scene& scene, const RenderOptions& options) { return renderChecked(checkedScene(scene), options); }

namespace {

RenderResult renderChecked(const Scene& scene, const RenderOptions& options)
{
    auto start = std::chrono::steady_clock::now();
    std::unique_ptr<tbb::global_control> threads;
    if (scene.render.threads > 0)
        threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                        size_t(scene.render.threads));
    RenderResult result;
    setupFilm(result.film, scene, scene.render.method, options.outputAovsOnly);

    switch (scene.render.method) {
    case Method::Single: {
        auto ctx = RenderContext::create(scene, true);
        auto t = std::chrono::steady_clock::now();
        renderMarched(*ctx, result.film, options);
        ctx->plan.stageSeconds.push_back(
            {"march", std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count()});
        result.plan = ctx->plan;
        break;
    }
    case Method::Wkb: {
        auto ctx = RenderContext::create(scene, true);
        wkb::WkbIntegrator l2plus(*ctx, ctx->plan);  // light volumes and pyramids; their stage times
        auto t = std::chrono::steady_clock::now();
        renderMarched(*ctx, result.film, options, &l2plus);
        ctx->plan.stageSeconds.push_back(
            {"march", std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count()});
        result.plan = ctx->plan;
        break;
    }
    case Method::Pathtrace: {
        auto ctx = RenderContext::create(scene, false);  // no shadow maps: NEE traces shadow rays
        auto t = std::chrono::steady_clock::now();
        renderPathtrace(*ctx, result.film, options, options.pathtrace);
        ctx->plan.stageSeconds.push_back(
            {"pathtrace", std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count()});
        result.plan = ctx->plan;
        break;
    }
    }

    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    auto& md = result.film.metadata;
    md.push_back({"version", NIMBUS_VERSION});
    md.push_back({"method", methodName(scene.render.method)});
    md.push_back({"seed", std::to_string(scene.render.seed)});
    md.push_back({"render_time", std::to_string(result.seconds)});
    md.push_back({"settings", settingsSummary(scene)});
    if (!scene.sourcePath.empty())
        md.push_back({"scene", scene.sourcePath});
    return result;
}

}  // namespace

}  // namespace nimbus
