#include "TileDriver.h"

#include "TileCulling.h"

#include "../scene/KernelScene.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <vector>

namespace nimbus {

namespace {

constexpr int kTile = 16;
// The most camera rays a worker marches at once (a multiple of eight: MarchEightRays groups).
constexpr size_t kBatchRays = 4096;

}  // namespace

void renderTiles(const RenderContext& ctx, const Integrator& integrator, Film& film, const RenderControl& control)
{
    const Scene& scene = *ctx.scene;
    const NbCamera cam = makeNbCamera(scene.camera);
    const int spp = scene.render.spp > 0 ? scene.render.spp : kDefaultMarchSpp;
    const int filterType = nbFilterType(scene.render.pixelFilter);
    const float filterWidth = scene.render.filterWidth;
    const double margin = filterMargin(filterWidth);
    const size_t nLights = ctx.lights.size();
    const int tilesX = (film.x1 - film.x0 + kTile - 1) / kTile, tilesY = (film.y1 - film.y0 + kTile - 1) / kTile;
    const int tileCount = std::max(0, tilesX * tilesY);
    std::atomic<int> done{0};
    // Stop inside tiles, not only between them (issue 18, item 3): the marches poll ctx.stop
    // (RenderControl.h); it is raised here when progress says stop, and read with the caller's
    // cancel flag before each tile row and after each march.
    auto stopped = [&] {
        return ctx.stop.raised() || (control.cancel && control.cancel->load(std::memory_order_relaxed));
    };

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
            put3(perLightAov[i],
                 make_float3(px.perLight[3 * i] * inv, px.perLight[3 * i + 1] * inv, px.perLight[3 * i + 2] * inv));
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

    // Holdouts (docs/geometry.md): each camera ray is clipped at the first holdout object (Embree,
    // eight rays at a time) or at the depth image's Z at its position, whichever is nearer.
    const EmbreeScene* holdoutGeometry = ctx.geometry && ctx.geometry->hasHoldouts() ? ctx.geometry.get() : nullptr;
    const HoldoutDepth* holdoutDepth = ctx.holdoutDepth.get();
    const bool holdouts = holdoutGeometry || holdoutDepth;

    // Tiles whose rays can meet an occupied brick of some volume (density or emission); the
    // others see only the background, where the integrator allows it (not wkb, which keeps its
    // own per-ray path). A holdout hides the background, so with both, every tile is marched.
    const bool skipEmpty =
        integrator.skipsEmptyTiles() && !(holdouts && nbMaxComponent(ctx.background) > 0.0f) &&
        !ctx.backgroundVaries();  // an environment map: each ray sees its own texel
    std::vector<char> seesBricks(size_t(tileCount), 1);
    if (skipEmpty) {
        std::fill(seesBricks.begin(), seesBricks.end(), 0);
        // Moving volumes (velocity blur) reach beyond their bricks: their grown box alone culls.
        bool bounded = !ctx.volumes.moving();
        for (const auto& v : ctx.volumes.volumes()) {
            bounded = bounded && markTilesSeeingBricks(cam, film.width, film.height, film.x0, film.y0, kTile, tilesX,
                                                       tilesY, v->density, v->worldFromIndex, seesBricks, margin);
            if (v->hasEmission())
                bounded =
                    bounded && markTilesSeeingBricks(cam, film.width, film.height, film.x0, film.y0, kTile, tilesX,
                                                     tilesY, v->emission, v->worldFromIndex, seesBricks, margin);
        }
        if (!bounded)
            std::fill(seesBricks.begin(), seesBricks.end(), 1);
    }

    const size_t perLightStride = 3 * nLights;
    tbb::parallel_for(tbb::blocked_range<int>(0, tileCount, 1), [&](const tbb::blocked_range<int>& r) {
        // One row of a tile at a time: every sample's ray first, then their marches together
        // (marchSingleRays takes eight at once where it can), then the pixels' sums.
        std::vector<float3> origins, directions;
        std::vector<float> tFar, sampleX, sampleY, sampleTime;
        std::vector<NbRng> rngs;
        std::vector<CameraSample> samples;
        std::vector<float> perLight;
        std::vector<PixelSum> rowSums;
        for (int tile = r.begin(); tile != r.end(); ++tile) {
            if (stopped())
                return;
            const int tx0 = film.x0 + (tile % tilesX) * kTile, ty0 = film.y0 + (tile / tilesX) * kTile;
            const int tx1 = std::min(tx0 + kTile, film.x1), ty1 = std::min(ty0 + kTile, film.y1);
            const bool empty =
                skipEmpty && (!seesBricks[size_t(tile)] || tileMissesBox(cam, film.width, film.height, tx0, ty0, tx1,
                                                                         ty1, ctx.volumes.movingBounds(), margin));
            for (int y = ty0; y < ty1; ++y) {
                if (stopped())
                    return;
                if (empty) {
                    for (int x = tx0; x < tx1; ++x)
                        store(x, y, background);
                    continue;
                }
                // The row's samples in batches of at most kBatchRays rays (a multiple of eight, so
                // the eight-ray marches group the same rays as one batch would): the buffers do not
                // grow with spp (issue 18, item 4), and each pixel's sum adds its samples in the
                // same order as ever, so the image does not depend on the batch size.
                const int width = tx1 - tx0;
                const size_t rowRays = size_t(width) * size_t(spp);
                rowSums.resize(size_t(width));
                for (PixelSum& sum : rowSums)
                    sum.reset(3 * nLights);
                for (size_t first = 0; first < rowRays; first += kBatchRays) {
                    const size_t rays = std::min(kBatchRays, rowRays - first);
                    origins.resize(rays), directions.resize(rays), rngs.resize(rays);
                    samples.assign(rays, CameraSample());
                    perLight.assign(rays * perLightStride, 0.0f);
                    sampleTime.resize(rays);
                    if (holdoutDepth)
                        sampleX.resize(rays), sampleY.resize(rays);
                    for (size_t i = 0; i < rays; ++i) {
                        const size_t k = first + i;  // the row's sample k: pixel k / spp, sample k % spp
                        const int x = tx0 + int(k / size_t(spp)), s = int(k % size_t(spp));
                        nb_uint pixelIndex = nb_uint(y) * nb_uint(film.width) + nb_uint(x);
                        NbRng& rng = rngs[i];
                        rng = nbRngStart(scene.render.seed, pixelIndex, nb_uint(s));
                        // The pixel filter by importance sampling (filter.h): an offset from the centre.
                        float jx = nbFilterSample(filterType, filterWidth, nbRngNext(&rng));
                        float jy = nbFilterSample(filterType, filterWidth, nbRngNext(&rng));
                        float time = nbRngNext(&rng);
                        nbCameraRay(cam, float(x) + 0.5f + jx, float(y) + 0.5f + jy, film.width, film.height, time,
                                    &origins[i], &directions[i]);
                        sampleTime[i] = time;
                        if (holdoutDepth)
                            sampleX[i] = float(x) + 0.5f + jx, sampleY[i] = float(y) + 0.5f + jy;
                    }
                    if (holdouts) {
                        tFar.assign(rays, INFINITY);
                        if (holdoutGeometry)
                            holdoutGeometry->holdoutHits(int(rays), origins.data(), directions.data(), tFar.data());
                        if (holdoutDepth)
                            for (size_t i = 0; i < rays; ++i) {
                                // Z along the view axis to t along the ray (d unit).
                                const float z = holdoutDepth->depthAt(sampleX[i], sampleY[i]);
                                const float cosAxis = dot(directions[i], nbCameraViewAxis(cam, sampleTime[i]));
                                if (z < INFINITY && cosAxis > 0.0f)
                                    tFar[i] = std::min(tFar[i], z / cosAxis);
                            }
                    }
                    integrator.marchRays(int(rays), origins.data(), directions.data(),
                                         holdouts ? tFar.data() : nullptr, sampleTime.data(), rngs.data(), samples.data(),
                                         perLight.data());
                    if (stopped())  // the marches may have ended early: nothing of theirs is kept
                        return;
                    for (size_t i = 0; i < rays; ++i)
                        rowSums[(first + i) / size_t(spp)].add(samples[i], perLight.data() + perLightStride * i);
                }
                for (int x = tx0; x < tx1; ++x)
                    store(x, y, rowSums[size_t(x - tx0)]);
            }
            int finished = ++done;
            if (!control.keepGoing(float(finished) / float(tileCount)))
                ctx.stop.raise();
        }
    });
    if (stopped())
        throw Cancelled();
}

}  // namespace nimbus
