#include "TileDriver.h"

#include "TileCulling.h"

#include "../render/AdaptiveSampling.h"
#include "../render/PixelStrata.h"
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

// The deep image's slice edges (DeepFilm.h): `slices` + 1 camera-space depths, evenly spaced over
// the volumes' bounds as seen from the camera at shutter open and close (metres along the view
// axis, never behind the eye). Empty bounds: one slice [0, 0].
std::vector<float> deepSliceEdges(const NbCamera& cam, const Bbox& bounds, int slices)
{
    float zNear = INFINITY, zFar = 0.0f;
    if (!bounds.empty())
        for (int shutter = 0; shutter < 2; ++shutter) {
            float3 o, d;
            nbCameraRay(cam, 0.0f, 0.0f, 1, 1, float(shutter), &o, &d);
            const float3 axis = nbCameraViewAxis(cam, float(shutter));
            for (int c = 0; c < 8; ++c) {
                const float3 p = make_float3(c & 1 ? bounds.hi.x : bounds.lo.x, c & 2 ? bounds.hi.y : bounds.lo.y,
                                             c & 4 ? bounds.hi.z : bounds.lo.z);
                const float z = std::max(0.0f, dot(p - o, axis));
                zNear = std::min(zNear, z), zFar = std::max(zFar, z);
            }
        }
    if (!(zNear < INFINITY))
        zNear = zFar = 0.0f;
    std::vector<float> edges(size_t(slices) + 1);
    for (int k = 0; k <= slices; ++k)
        edges[size_t(k)] = k == slices ? zFar : zNear + (zFar - zNear) * (float(k) / float(slices));
    return edges;
}

// A pixel of a tile row's sampling round: its offset in the row, its first sample, its count.
struct RoundPixel {
    int offset, first, count;
};

}  // namespace

void renderTiles(const RenderContext& ctx, const Integrator& integrator, Film& film, const RenderControl& control,
                 TileSampleCounts* counts)
{
    const Scene& scene = *ctx.scene;
    const NbCamera cam = makeNbCamera(scene.camera);
    const int spp = scene.render.spp > 0 ? scene.render.spp : kDefaultMarchSpp;
    const AdaptiveSampling adaptive = adaptiveSamplingOf(scene.render, spp);
    std::atomic<long long> samplesTaken{0}, pixelsMarched{0}, pixelsAtMost{0};
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

    // One pixel's samples, summed: the radiance terms, the opacity-weighted depth, the per-light
    // L1, and the count, sum and sum of squares of the luminance of L0 + L1 (AdaptiveSampling.h).
    struct PixelSum {
        CameraSample sum;
        float depthSum = 0.0f, depthWeight = 0.0f;
        std::vector<float> perLight;
        PixelMoments moments;
        void reset(size_t n)
        {
            sum = CameraSample();
            sum.transmittance = splat(0.0f);
            depthSum = depthWeight = 0.0f;
            perLight.assign(n, 0.0f);
            moments = PixelMoments();
        }
        void add(const CameraSample& cs, const float* light)
        {
            moments.add(nbAverage(cs.L0 + cs.L1));
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
    auto store = [&](int x, int y, const PixelSum& px) {
        const float inv = 1.0f / float(std::max(1, px.moments.n));
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
    // others see only the background, where the integrator allows it (single and wkb: wkb's L2+
    // is sigma_s times in-scattered light at camera points, none outside the bricks; its images
    // are bit-identical to marching those tiles). A holdout hides the background, so with both,
    // every tile is marched.
    // With an environment map each ray of an empty tile sees its own texel: the rays are made,
    // as a march would make them, and read the map without marching (emptyPixel).
    const bool backgroundVaries = ctx.backgroundVaries();
    const bool skipEmpty = integrator.skipsEmptyTiles() &&
                           !(holdouts && (nbMaxComponent(ctx.background) > 0.0f || backgroundVaries));
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

    // Camera sample s of pixel (x, y): its ray and its image position and time (as the holdout
    // depth map reads them), the filter and time drawn from the pixel's sample stream. The
    // sample belongs to the round of `count` samples that starts at sample `first` (the first
    // spp, then each adaptive round): its random numbers are stratified over that round.
    auto cameraSample = [&](int x, int y, int s, int first, int count, NbRng& rng, float3& o, float3& d, float& px,
                            float& py, float& time) {
        const nb_uint pixelIndex = nb_uint(y) * nb_uint(film.width) + nb_uint(x);
        rng = nbRngStart(scene.render.seed, pixelIndex, nb_uint(s));
        // The pixel filter by importance sampling (filter.h): an offset from the centre, its two
        // random numbers stratified over the round's samples, and the shutter time too
        // (PixelStrata.h); each round its own strata.
        const uint32_t roundSeed = first == 0 ? scene.render.seed : scene.render.seed ^ nbPcgHash(nb_uint(first));
        const PixelSampleNumbers u = pixelSampleNumbers(roundSeed, pixelIndex, s - first, count, rng);
        const float jx = nbFilterSample(filterType, filterWidth, u.ux);
        const float jy = nbFilterSample(filterType, filterWidth, u.uy);
        time = u.time;
        px = float(x) + 0.5f + jx, py = float(y) + 0.5f + jy;
        nbCameraRay(cam, px, py, film.width, film.height, time, &o, &d);
    };
    // A pixel of an empty tile under an environment map: each sample what a march of a ray that
    // misses every volume gathers (the background along it), summed the same way.
    const std::vector<float> none(3 * nLights, 0.0f);  // no light's L1 (read only, shared)
    // Its samples in the rounds a marched pixel's would take (AdaptiveSampling.h).
    auto emptyPixel = [&](int x, int y, PixelSum& sum) {
        sum.reset(3 * nLights);
        for (int first = 0, count = spp; count > 0; first = sum.moments.n, count = adaptive.moreSamples(sum.moments))
            for (int s = first; s < first + count; ++s) {
                NbRng rng;
                float3 o, d;
                float px, py, time;
                cameraSample(x, y, s, first, count, rng, o, d, px, py, time);
                CameraSample miss;
                miss.L0 = ctx.backgroundAlong(d);
                sum.add(miss, none.data());
            }
    };
    // Deep output (DeepFilm.h): every camera sample is marched again up to each slice's back edge;
    // the pixel's sums there give its deep samples. What the background adds past the last edge is
    // one sample more, so the slices leave room for it where the background can be seen.
    DeepFilm* deep = film.deep.get();
    std::vector<float> deepEdges;
    if (deep) {
        const bool backgroundSeen = nbMaxComponent(ctx.background) > 0.0f || ctx.backgroundVaries();
        const int slices = std::max(1, deep->maxSamples - (backgroundSeen ? 1 : 0));
        deepEdges = deepSliceEdges(cam, ctx.volumes.worldBounds(), slices);
    }
    const size_t deepSlices = deep ? deepEdges.size() - 1 : 0;
    // A pixel's sums in front of each slice edge and for the whole march (DeepCurve's L and T,
    // summed over the pixel's samples; entry 0 is implicit).
    struct DeepSum {
        std::vector<Rgb> L;
        std::vector<float> T;
        void reset(size_t slices)
        {
            L.assign(slices + 2, splat(0.0f));
            T.assign(slices + 2, 0.0f);
        }
    };
    auto storeDeep = [&](int x, int y, const DeepSum& sum, int samples) {
        const float inv = 1.0f / float(std::max(1, samples));
        DeepCurve curve;
        curve.edges = deepEdges;
        curve.L.resize(deepSlices + 2);
        curve.T.resize(deepSlices + 2);
        curve.L[0] = splat(0.0f), curve.T[0] = 1.0f;
        for (size_t k = 1; k < deepSlices + 2; ++k)
            curve.L[k] = sum.L[k] * inv, curve.T[k] = sum.T[k] * inv;
        deep->at(x, y) = deepSamplesOf(std::move(curve), deep->maxSamples);
    };
    // An empty tile's pixel: nothing in the slices, the background behind them.
    DeepSum deepBackground;
    if (deep) {
        deepBackground.reset(deepSlices);
        for (size_t k = 1; k < deepSlices + 2; ++k)
            deepBackground.T[k] = float(spp);
        deepBackground.L[deepSlices + 1] = background.sum.L0;
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
        std::vector<NbRng> deepRngs, rngStarts;
        std::vector<CameraSample> deepSamples;
        std::vector<float> deepPerLight, deepTFar, cosAxis;
        std::vector<DeepSum> rowDeep;
        std::vector<RoundPixel> roundPixels, nextPixels;
        std::vector<int> batchPixel;  // each batch sample's pixel (offset in the row)
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
                    for (int x = tx0; x < tx1; ++x) {
                        if (backgroundVaries) {
                            rowSums.resize(1);
                            emptyPixel(x, y, rowSums[0]);
                            store(x, y, rowSums[0]);
                            if (deep) {  // the pixel's own background behind the empty slices
                                DeepSum own = deepBackground;
                                const int n = rowSums[0].moments.n;
                                std::fill(own.T.begin() + 1, own.T.end(), float(n));
                                own.L[deepSlices + 1] = rowSums[0].sum.L0;
                                storeDeep(x, y, own, n);
                            }
                        } else {
                            store(x, y, background);
                            if (deep)
                                storeDeep(x, y, deepBackground, spp);
                        }
                    }
                    continue;
                }
                // The row's samples in rounds: every pixel's spp, then (AdaptiveSampling.h) as many
                // again for each pixel whose mean is still too noisy, until none is or each has
                // reached the most. A round's samples go in batches of at most kBatchRays rays (a
                // multiple of eight, so the eight-ray marches group the same rays as one batch
                // would): the buffers do not grow with spp (issue 18, item 4), and each pixel's sum
                // adds its samples in the same order as ever, so the image does not depend on the
                // batch size.
                const int width = tx1 - tx0;
                rowSums.resize(size_t(width));
                for (PixelSum& sum : rowSums)
                    sum.reset(3 * nLights);
                if (deep) {
                    rowDeep.resize(size_t(width));
                    for (DeepSum& sum : rowDeep)
                        sum.reset(deepSlices);
                }
                // The round's pixels (offsets in the row) and each one's first sample and count.
                roundPixels.clear();
                for (int i = 0; i < width; ++i)
                    roundPixels.push_back(RoundPixel{i, 0, spp});
                while (!roundPixels.empty()) {
                    size_t roundRays = 0;
                    for (const RoundPixel& rp : roundPixels)
                        roundRays += size_t(rp.count);
                    samplesTaken += (long long)roundRays;
                    // The round's next sample: pixel roundPixels[p], its sample first + j.
                    size_t p = 0;
                    int j = 0;
                    for (size_t first = 0; first < roundRays; first += kBatchRays) {
                        const size_t rays = std::min(kBatchRays, roundRays - first);
                        origins.resize(rays), directions.resize(rays), rngs.resize(rays);
                        samples.assign(rays, CameraSample());
                        perLight.assign(rays * perLightStride, 0.0f);
                        sampleTime.resize(rays);
                        if (holdoutDepth || deep)
                            sampleX.resize(rays), sampleY.resize(rays);
                        batchPixel.resize(rays);
                        for (size_t i = 0; i < rays; ++i) {
                            while (j >= roundPixels[p].count)
                                ++p, j = 0;
                            const RoundPixel& rp = roundPixels[p];
                            batchPixel[i] = rp.offset;
                            const int x = tx0 + rp.offset, s = rp.first + j++;
                            float px, py;
                            cameraSample(x, y, s, rp.first, rp.count, rngs[i], origins[i], directions[i], px, py,
                                         sampleTime[i]);
                            if (holdoutDepth || deep)
                                sampleX[i] = px, sampleY[i] = py;
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
                        if (deep)
                            rngStarts.assign(rngs.begin(), rngs.end());  // each prefix march replays them
                        integrator.marchRays(int(rays), origins.data(), directions.data(),
                                             holdouts ? tFar.data() : nullptr, sampleTime.data(), rngs.data(),
                                             samples.data(), perLight.data());
                        if (stopped())  // the marches may have ended early: nothing of theirs is kept
                            return;
                        for (size_t i = 0; i < rays; ++i)
                            rowSums[size_t(batchPixel[i])].add(
                                samples[i], perLight.data() + perLightStride * i);
                        if (deep) {
                            // The whole march, then the prefix up to each slice edge z_k: the ray stops
                            // at t = z_k / cos(ray, view axis), as a depth-map holdout at z_k would stop
                            // it (the marches cut there on their own lattice).
                            cosAxis.resize(rays);
                            for (size_t i = 0; i < rays; ++i) {
                                cosAxis[i] = dot(directions[i], nbCameraViewAxis(cam, sampleTime[i]));
                                DeepSum& sum = rowDeep[size_t(batchPixel[i])];
                                sum.L[deepSlices + 1] += samples[i].L0 + samples[i].L1 + samples[i].L2plus;
                                sum.T[deepSlices + 1] += nbAverage(samples[i].transmittance);
                            }
                            deepTFar.resize(rays);
                            for (size_t k = 1; k <= deepSlices; ++k) {
                                for (size_t i = 0; i < rays; ++i) {
                                    const float tEdge = cosAxis[i] > 0.0f ? deepEdges[k] / cosAxis[i] : INFINITY;
                                    deepTFar[i] = holdouts ? std::min(tFar[i], tEdge) : tEdge;
                                }
                                deepRngs.assign(rngStarts.begin(), rngStarts.end());
                                deepSamples.assign(rays, CameraSample());
                                deepPerLight.assign(rays * perLightStride, 0.0f);
                                integrator.marchRays(int(rays), origins.data(), directions.data(), deepTFar.data(),
                                                     sampleTime.data(), deepRngs.data(), deepSamples.data(),
                                                     deepPerLight.data());
                                if (stopped())
                                    return;
                                for (size_t i = 0; i < rays; ++i) {
                                    DeepSum& sum = rowDeep[size_t(batchPixel[i])];
                                    sum.L[k] += deepSamples[i].L0 + deepSamples[i].L1 + deepSamples[i].L2plus;
                                    sum.T[k] += nbAverage(deepSamples[i].transmittance);
                                }
                            }
                        }
                    }
                    // The next round: the pixels whose mean is still too noisy, as many samples again
                    // (at most up to the most; AdaptiveSampling.h).
                    nextPixels.clear();
                    for (const RoundPixel& rp : roundPixels) {
                        const PixelMoments& m = rowSums[size_t(rp.offset)].moments;
                        const int more = adaptive.moreSamples(m);
                        if (more > 0)
                            nextPixels.push_back(RoundPixel{rp.offset, m.n, more});
                    }
                    roundPixels.swap(nextPixels);
                }
                for (int x = tx0; x < tx1; ++x) {
                    const PixelSum& sum = rowSums[size_t(x - tx0)];
                    store(x, y, sum);
                    if (deep)
                        storeDeep(x, y, rowDeep[size_t(x - tx0)], sum.moments.n);
                    ++pixelsMarched;
                    if (sum.moments.n >= adaptive.maxSpp)
                        ++pixelsAtMost;
                }
            }
            int finished = ++done;
            if (!control.keepGoing(float(finished) / float(tileCount)))
                ctx.stop.raise();
        }
    });
    if (stopped())
        throw Cancelled();
    if (counts) {
        counts->samples = samplesTaken.load();
        counts->pixels = pixelsMarched.load();
        counts->pixelsAtMost = pixelsAtMost.load();
        counts->baseSpp = spp;
        counts->maxSpp = adaptive.enabled() ? adaptive.maxSpp : spp;
    }
}

}  // namespace nimbus
