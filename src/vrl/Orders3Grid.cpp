#include "Orders3Grid.h"

#include "../pathtracer/PathtraceScene.h"
#include "../render/SphericalHarmonics.h"
#include "SkinCells.h"
#include "ViewFocus.h"
#include "VrlLightPass.h"
#include "VrlMedium.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace nimbus::vrl {

namespace {

// Partial grids summed in parallel (a fixed number, not the thread count: determinism).
constexpr int kPartials = 8;
// Light paths per light-pass call (bounds the memory of the segment list).
constexpr long long kBatch = 8192;
// Where a segment's transmittance (times its roulette weight) falls below this, Russian roulette
// decides whether its deposit goes on, with survival T r / kRoulette and r divided by it: unbiased,
// and a segment costs a few optical depths of steps however thick the medium.
constexpr float kRoulette = 0.05f;
// Passes of the [1 2 1] / 4 filter over the finished cache (a Gaussian of sigma 0.7 cells): fitted
// on the calibration suite (docs/validation.md, "Orders 3 and up, traced"): with SH order 2, one pass lowers the
// cache's noise enough to meet the targets on 4 of 9 scenes instead of 2, at the price of a bias
// where orders 3+ live in a skin thinner than a cell (slab_lit, absorbing_backscatter).
constexpr int kBlurPasses = 1;
// The deposits' random stream, keyed apart from the light paths'.
constexpr uint32_t kDepositKey = 0x64657030u;

// Deposits one segment into grid data `out`, in the cells' layer `layer`: its expected track
// length in each cell it crosses (W/m^2 once divided by the cell's volume), or in a skin cell
// (SkinCells.h) one point's estimate of int sigma_s T T_cam dt (W, until resolveSkinCells).
void deposit(const RenderContext& ctx, const wkb::RadianceGrid& grid, const SkinCells& skin, const Vrl& v, int layer,
             float h, NbRng& rng, float* out)
{
    const size_t F = size_t(grid.floatsPerCell());
    out += size_t(layer) * wkb::RadianceGrid::kFloats;
    double y[wkb::RadianceGrid::kCoeffs];
    shEvaluate(wkb::RadianceGrid::kOrder, v.dir, y);
    const float invV = 1.0f / grid.cellVolume();
    float T[3] = {1.0f, 1.0f, 1.0f};
    float r = 1.0f;  // the roulette's weight
    const float flux[3] = {v.flux.x, v.flux.y, v.flux.z};
    grid.walk(v.origin, v.dir, v.t0, v.t1, [&](size_t cell, float ta, float tb) {
        // int T dt over [ta, tb], the extinction piecewise constant over steps of at most h
        // (sampled at each step's midpoint), each step's integral exact: T (1 - e^{-s dt}) / s.
        const int skinSlot = skin.slotOf(cell);
        int n = std::max(1, int(std::ceil((tb - ta) / h)));
        if (skinSlot >= 0)
            // A skin cell's integrand varies with T_cam over a mean free path: its steps are at most
            // half an optical depth (the largest extinction of the stretch's ends and middle),
            // where a voxel-long step would spread a face's ramp as if it were uniform.
            n = std::max(n, skinSubSteps(ctx.volumes, v.origin + v.dir * ta, v.dir, tb - ta));
        const float dt = (tb - ta) / float(n);
        float I[3] = {0, 0, 0};
        bool alive = true;
        SkinPoint point;
        for (int k = 0; k < n && alive; ++k) {
            const MediumSample m = ctx.volumes.sample(v.origin + v.dir * (ta + (float(k) + 0.5f) * dt));
            const float st[3] = {m.sigma_t.x, m.sigma_t.y, m.sigma_t.z};
            if (skinSlot >= 0) {
                const float rT[3] = {r * T[0], r * T[1], r * T[2]};
                point.offer(ta + float(k) * dt, dt, rT, m.sigma_s, m.sigma_t, nbRngNext(&rng));
            }
            for (int c = 0; c < 3; ++c) {
                const float x = st[c] * dt;
                const float e = std::exp(-x);
                I[c] += r * T[c] * (x > 1e-4f ? (1.0f - e) / st[c] : dt * (1.0f - 0.5f * x));
                T[c] *= e;
            }
            const float tr = r * std::max(T[0], std::max(T[1], T[2]));
            if (tr < kRoulette) {
                const float q = tr / kRoulette;
                if (nbRngNext(&rng) >= q)
                    alive = false;
                else
                    r /= q;
            }
        }
        float* d = out + cell * F;
        if (skinSlot < 0) {
            for (int jm = 0; jm < wkb::RadianceGrid::kCoeffs; ++jm)
                for (int c = 0; c < 3; ++c)
                    d[3 * jm + c] += float(y[jm]) * flux[c] * I[c] * invV;
        } else if (point.any()) {
            float e[3];
            const float3 p = point.draw(v.origin, v.dir, nbRngNext(&rng), e);
            const Rgb Tc = skin.inView(p) ? cameraTransmittance(ctx.volumes, p, skin.camera) : splat(0.0f);
            const float w[3] = {flux[0] * e[0] * Tc.x, flux[1] * e[1] * Tc.y, flux[2] * e[2] * Tc.z};
            if (w[0] > 0.0f || w[1] > 0.0f || w[2] > 0.0f)
                for (int jm = 0; jm < wkb::RadianceGrid::kCoeffs; ++jm)
                    for (int c = 0; c < 3; ++c)
                        d[3 * jm + c] += float(y[jm]) * w[c];
        }
        return alive;
    });
}

// One pass of the separable [1 2 1] / 4 filter along each axis (edges clamped), in place, the
// skin cells read but left as they are (their camera-weighted means are resolved already);
// scratch: a buffer of the grid's size. stop: polled per slice (up to 512^2 cells each).
void blur(wkb::RadianceGrid& grid, const SkinCells& skin, std::vector<float>& scratch, const StopFlag& stop)
{
    const int n[3] = {grid.size(0), grid.size(1), grid.size(2)};
    const size_t stride[3] = {1, size_t(n[0]), size_t(n[0]) * size_t(n[1])};
    const int F = grid.floatsPerCell();
    std::vector<float>& data = grid.data();
    for (int axis = 0; axis < 3; ++axis) {
        if (n[axis] < 2)
            continue;
        scratch = data;
        tbb::parallel_for(0, n[2], [&](int z) {
            throwIfStopped(&stop);
            for (int y = 0; y < n[1]; ++y)
                for (int x = 0; x < n[0]; ++x) {
                    const int c[3] = {x, y, z};
                    const size_t i = size_t(z) * stride[2] + size_t(y) * stride[1] + size_t(x);
                    if (skin.slotOf(i) >= 0)
                        continue;
                    const size_t lo = c[axis] > 0 ? i - stride[axis] : i;
                    const size_t hi = c[axis] + 1 < n[axis] ? i + stride[axis] : i;
                    for (int k = 0; k < F; ++k)
                        data[i * F + k] = 0.25f * scratch[lo * F + k] + 0.5f * scratch[i * F + k] +
                                          0.25f * scratch[hi * F + k];
                }
        });
    }
}

}  // namespace

long long orders3PathsFor(const Scene& scene)
{
    const RenderSettings& r = scene.render;
    if (r.wkbOrders3Paths > 0)
        return r.wkbOrders3Paths;
    const double spp = r.spp > 0 ? r.spp : kDefaultMarchSpp;
    const double samples = double(std::max(1, scene.camera.width)) * double(std::max(1, scene.camera.height)) * spp;
    const double p = 1024.0 * std::sqrt(samples);
    return (long long)std::llround(std::clamp(p, 16384.0, double(1 << 24)));
}

size_t orders3FillBytes(const RenderContext& ctx, const Orders3Options& options)
{
    if (ctx.volumes.empty() || options.paths <= 0)
        return 0;
    const size_t cells = wkb::RadianceGrid::cellCountFor(ctx.volumes.worldBounds(), 0.0f, options.maxCells);
    size_t worst = 0;  // over the layer counts traceOrders3 can choose: the grid plus its partials
    for (int layers = 1; layers <= std::max(1, int(ctx.lights.size())); ++layers)
        worst = std::max(worst, size_t(layers) * size_t(1 + std::max(2, kPartials / layers)));
    return cells * size_t(wkb::RadianceGrid::kFloats) * sizeof(float) * worst + skinCellsBytes(cells);
}

std::shared_ptr<const wkb::RadianceGrid> traceOrders3(const RenderContext& ctx, const Orders3Options& options,
                                                      Orders3Report* report)
{
    if (ctx.volumes.empty() || options.paths <= 0)
        return nullptr;
    PathtraceScene ps = buildPathtraceScene(ctx);
    VrlMedium medium(ps);
    LightPass pass(ctx, ps, medium, 0);  // unbounded: wkb has no depth cap
    if (pass.empty())
        return nullptr;
    // Layers (RadianceGrid "Layers"): the light pass's light i deposits into layer layerOf[i].
    const size_t nl = ps.lights.size();
    std::vector<int> layerOf(nl, 0), layerLight;
    if (nl == 1) {
        layerLight = {ps.lightEntry[0]};
    } else {
        auto written = [&](size_t i) {
            const int e = ps.lightEntry[i];
            return e >= 0 && size_t(e) < options.perLightAovs.size() && options.perLightAovs[size_t(e)] != 0;
        };
        bool others = false;
        for (size_t i = 0; i < nl; ++i)
            if (written(i)) {
                layerOf[i] = int(layerLight.size());
                layerLight.push_back(ps.lightEntry[i]);
            } else {
                others = true;
            }
        if (layerLight.empty()) {
            layerLight = {-1};  // no per-light AOV: one layer, every light summed
        } else if (others) {
            for (size_t i = 0; i < nl; ++i)
                if (!written(i))
                    layerOf[i] = int(layerLight.size());
            layerLight.push_back(-1);
        }
    }
    auto grid = std::make_shared<wkb::RadianceGrid>();
    grid->init(ctx.volumes.worldBounds(), 0.0f, options.maxCells, int(layerLight.size()));
    if (grid->empty())
        return nullptr;
    grid->setLayerLights(layerLight);
    const SkinCells skin = options.skinCells ? findSkinCells(ctx, *grid) : SkinCells{};
    const EmissionFocus focus = options.focus ? findViewFocus(ctx, grid->cellSize(), pass.boundsRadius()) : EmissionFocus{};
    pass.setFocus(focus);
    pass.setAimAtVolumes(options.focus);
    if (report) {
        report->cells = grid->cellCount();
        report->skinCells = skin.count();
        report->aimedAtView = focus.active;
        report->focusRadius = focus.radius;
    }
    // Transmittance steps: at most the finest density voxel (each cell's stretch is split evenly).
    const float h = std::fmax(1e-6f, ctx.volumes.minVoxelSize());

    const long long batches = (options.paths + kBatch - 1) / kBatch;
    const int perBatch = int((options.paths + batches - 1) / batches);
    const float scale = 1.0f / float(batches);  // each batch's flux is divided by its own path count
    const size_t floats = grid->data().size();
    // Fewer partial grids with more layers: the partials' memory stays that of kPartials one-layer
    // grids (a fixed count for a scene: deterministic).
    const int partials = std::max(2, kPartials / grid->layers());
    std::vector<std::vector<float>> partial(size_t(partials), std::vector<float>(floats, 0.0f));
    std::vector<Vrl> kept;
    for (long long b = 0; b < batches; ++b) {
        // A stopped render (RenderControl.h): the paths end early, the deposits stop within a few
        // hundred segments, and the grid is dropped with the render.
        throwIfStopped(&ctx.stop);
        std::vector<Vrl> all = pass.trace(options.seed, uint32_t(b), perBatch);
        throwIfStopped(&ctx.stop);
        kept.clear();
        for (const Vrl& v : all)
            if (v.order >= options.firstOrder) {
                kept.push_back(v);
                kept.back().flux = kept.back().flux * scale;
            }
        const size_t n = kept.size();
        tbb::parallel_for(0, partials, [&](int p) {
            const size_t lo = n * size_t(p) / size_t(partials), hi = n * size_t(p + 1) / size_t(partials);
            for (size_t i = lo; i < hi; ++i) {
                if ((i - lo) % kStopPollInterval == kStopPollInterval - 1)
                    throwIfStopped(&ctx.stop);
                NbRng rng = nbRngStart(options.seed ^ kDepositKey, uint32_t(i), uint32_t(b));
                deposit(ctx, *grid, skin, kept[i], layerOf[size_t(kept[i].light)], h, rng, partial[size_t(p)].data());
            }
        });
    }
    throwIfStopped(&ctx.stop);
    std::vector<float>& data = grid->data();
    for (int p = 0; p < partials; ++p)
        for (size_t i = 0; i < floats; ++i)
            data[i] += partial[size_t(p)][i];
    resolveSkinCells(skin, *grid, partial[1]);
    for (int k = 0; k < kBlurPasses; ++k)
        blur(*grid, skin, partial[0], ctx.stop);
    return grid;
}

}  // namespace nimbus::vrl
