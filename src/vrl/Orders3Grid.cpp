#include "Orders3Grid.h"

#include "../../kernels/shared/geometry.h"
#include "../pathtracer/PathtraceScene.h"
#include "../scene/KernelScene.h"
#include "../single/ScatterPoints.h"
#include "../single/SingleScatter.h"
#include "CameraLattice.h"
#include "CellReach.h"
#include "ShadowCasters.h"
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
// Light paths per batch: the step of the adaptive count's rounds and of a fixed count's split.
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

// The adaptive count (render.wkb_orders3_paths 0): the first round's light paths, the pilot camera
// rays that read the cache's noise (a lattice of at most kPilotSide on the image's longer side),
// the rounds at most, and the noise the cache may add to the image: its relMSE there, fitted on the
// calibration suite (docs/validation.md "The cache's paths from its measured noise").
constexpr long long kFirstRoundPaths = 65536;
constexpr int kPilotSide = 32;
constexpr int kMaxRounds = 3;
// kCacheNoiseTarget on calibration: 0.001, 0.002 and 0.004 all meet 9 of 9 (both suites rendered
// in 46.7, 41.2 and 36.8 s); 0.002 is the cheapest that keeps every scene at least 15% under the
// relMSE target of 0.01 (at 0.004 cumulus_lit is at 0.0092; docs/validation.md).
constexpr double kCacheNoiseTarget = 0.002;
// P = kBalance sqrt(A x camera samples): the count least in error x time (docs/wkb.md "How many
// light paths"), kBalance = sqrt(t0 / (samples a e0)) measured on the calibration suite's
// cumulus_lit with order 2 in the cache and the cache read by L1's march (2026-12-07: relMSE
// 0.0154, 0.0068, 0.0049 at 65536, 262144 and 1048576 paths give A 739 and e0 0.0041; t0 / samples
// 0.5 us at 64x64 and 256x256, a 3.1 us per path). Until then 34, from t0 / samples 24 us: the
// camera's march with order 2 traced.
constexpr double kBalance = 6.0;
// The most paths the adaptive count may take, per square root of the camera's samples
// (orders3PathCap): the smallest power of two under which every calibration scene's count reaches
// kCacheNoiseTarget (the largest ask, cumulus_dense_against's, 7.2 M paths at 64x64 and 4 spp,
// against 8.4 M; 4096 capped it at 0.52 M: beauty relMSE 0.0335 against 0.0113; docs/validation.md
// "Session 32"). Only scenes whose cache's noise asks for more than the old cap are slower.
constexpr double kPathCapPerSample = 65536.0;
// The cache's cells along the box's longest side where render.wkb_orders3_grid is 0 (its
// default): kGridCells, or more, up to kMaxGridCells, where the densest medium would make a cell
// more than kMaxCellTransportLengths transport mean free paths 1 / (sigma_t (1 - g omega)) across
// without making it a skin cell (SkinCells.h: 2 transport lengths, or 1 diffusion length). Under
// a dense medium's face the radiance toward the camera bends over about a transport length (the
// diffusion solution's extrapolated zero lies 0.71 of one outside the face), and the camera sees
// about a mean free path into it: a cell of 0.75 transport lengths read trilinearly left the dark
// face of a sphere of optical radius 30 at albedo 0.9995 +7% bright. Fitted on the calibration
// suite's two scenes in that regime (docs/validation.md "Session 32": sphere_dense_side, cells
// of 0.70, 0.47 and 0.35 transport lengths: beauty relMSE 0.0051, 0.0038, 0.0038 and L2plus -1.3%,
// -1.1%, -0.8%; cumulus_dense_against, 0.96, 0.64, 0.48: 0.0296, 0.0161, 0.0134): finer is no
// worse down to the smallest tried, which 96 cells reach on both.
constexpr int kGridCells = 48;
constexpr double kMaxCellTransportLengths = 0.375;
constexpr int kMaxGridCells = 96;
// The pilot rays' random stream, keyed apart from the others.
constexpr uint32_t kPilotKey = 0x70696c6fu;

// The phase function toward the viewer at a point: the one volume's, or the sigma_s-weighted
// mixture where there are several (PhaseMix; where none scatters, the first volume's stands in:
// the read multiplies by sigma_s there, which is 0).
struct ViewerPhase {
    float3 viewer;
    std::vector<NbPhase> phases;
    // p(w . wo(x)), wo(x) the unit direction from x to the viewer (1/sr).
    float operator()(const VolumeSet& volumes, PhaseMix& mix, float3 x, float3 w) const
    {
        const float3 toViewer = viewer - x;
        const float len = length(toViewer);
        const float c = len > 0.0f ? dot(w, toViewer) / len : 1.0f;
        if (phases.size() == 1)
            return nbPhaseEval(phases[0], c);
        mix.at(volumes, x);
        return mix.eval(c);
    }
};

// Deposits one segment into grid data `out`, in the cells' layer `layer`: its expected track
// length in each cell it crosses, each step weighted by the phase function toward the viewer
// (W/(m^2 sr) once divided by the cell's volume), or in a skin cell (SkinCells.h) one point's
// estimate of int sigma_s T T_cam p dt (W/sr, until resolveSkinCells).
void deposit(const RenderContext& ctx, const wkb::RadianceGrid& grid, const SkinCells& skin, const ViewerPhase& phase,
             const std::vector<uint8_t>& reach, const Vrl& v, int layer, float h, NbRng& rng, float* out)
{
    const size_t F = size_t(grid.floatsPerCell());
    out += size_t(layer) * wkb::RadianceGrid::kFloats;
    thread_local PhaseMix mix;
    mix.use(phase.phases);
    const float invV = 1.0f / grid.cellVolume();
    float T[3] = {1.0f, 1.0f, 1.0f};
    float r = 1.0f;  // the roulette's weight
    const float flux[3] = {v.flux.x, v.flux.y, v.flux.z};
    // VolumeSet::sample's per-volume outputs, sized once per segment rather than per step.
    thread_local std::vector<float> weights;
    thread_local std::vector<BrickGrid::Stencil> stencils;
    weights.resize(ctx.volumes.volumes().size());
    stencils.resize(ctx.volumes.volumes().size());
    grid.walk(v.origin, v.dir, v.t0, v.t1, [&](size_t cell, float ta, float tb) {
        // int T p dt over [ta, tb], the extinction and the phase value piecewise constant over
        // steps of at most h (sampled at each step's midpoint), each step's integral of T exact:
        // T (1 - e^{-s dt}) / s.
        // Cells no read reaches are crossed without a deposit; in a cell without medium T stays
        // as it is and no step reads the medium (CellReach.h).
        const uint8_t where = reach[cell];
        if (where == kCellUnread)
            return true;
        const int skinSlot = skin.slotOf(cell);
        const bool clear = where == kCellClear && skinSlot < 0 && phase.phases.size() == 1;
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
            const float3 x = v.origin + v.dir * (ta + (float(k) + 0.5f) * dt);
            if (clear) {
                const float p = phase(ctx.volumes, mix, x, v.dir);
                for (int c = 0; c < 3; ++c)
                    I[c] += p * r * T[c] * dt;
                continue;
            }
            const MediumSample m = ctx.volumes.sample(x, weights.data(), stencils.data());
            const float st[3] = {m.sigma_t.x, m.sigma_t.y, m.sigma_t.z};
            if (skinSlot >= 0) {
                const float rT[3] = {r * T[0], r * T[1], r * T[2]};
                point.offer(ta + float(k) * dt, dt, rT, m.sigma_s, m.sigma_t, nbRngNext(&rng));
            }
            const float p = skinSlot < 0 ? phase(ctx.volumes, mix, x, v.dir) : 0.0f;
            const bool grey = st[0] == st[1] && st[1] == st[2];  // one exponential serves all three
            float e = 0.0f, w = 0.0f;
            for (int c = 0; c < 3; ++c) {
                if (c == 0 || !grey) {
                    const float y = st[c] * dt;
                    e = std::exp(-y);
                    w = y > 1e-4f ? (1.0f - e) / st[c] : dt * (1.0f - 0.5f * y);
                }
                I[c] += p * r * T[c] * w;
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
            for (int c = 0; c < 3; ++c)
                d[c] += flux[c] * I[c] * invV;
        } else if (point.any()) {
            float e[3];
            const float3 x = point.draw(v.origin, v.dir, nbRngNext(&rng), e);
            const Rgb Tc = skin.inView(x) ? cameraTransmittance(ctx.volumes, x, skin.camera) : splat(0.0f);
            const float p = phase(ctx.volumes, mix, x, v.dir);
            const float w[3] = {flux[0] * e[0] * Tc.x, flux[1] * e[1] * Tc.y, flux[2] * e[2] * Tc.z};
            for (int c = 0; c < 3; ++c)
                d[c] += p * w[c];
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

// Where a deposited segment goes. The cache needs, at each scattering vertex x (incoming
// direction wi, phase function p), the expectation over the outgoing direction w ~ p(wi . w) of
// the segment's deposit D(w) = int T p(w . wo) dt, wo toward the camera. The light path's own w
// estimates it with one sample whose weight p(w . wo) spans 190x its mean at g 0.9: the rare
// segments that head for the camera carry the cache. The deposit draws its own w instead, from
//
//     q(w) = (p(wi . w) + p(w . wo(x))) / 2,
//
// the phase lobe around wi and the same lobe around the direction to the camera, and weighs it
// by p(wi . w) / q(w) (<= 2): E_q[p D / q] = int p(wi . w) D(w) dw, unbiased, whatever wo is. The
// path goes on along its own w (the light pass's), so only the deposits move. v: a segment that
// leaves a scattering vertex, wi the direction of the segment that arrived there. False where w
// misses the volumes. Shadow casters end the segment as they end the light pass's.
bool aimDeposit(const PathtraceScene& ps, const VrlMedium& medium, float3 viewer, float3 wi, Vrl& v, NbRng& rng)
{
    const float3 toViewer = viewer - v.origin;
    const float len = length(toViewer);
    const float3 wo = len > 0.0f ? toViewer / len : wi;
    const float u = nbRngNext(&rng), u0 = nbRngNext(&rng), u1 = nbRngNext(&rng), u2 = nbRngNext(&rng);
    const float3 w = nbPhaseSample(v.phase, u < 0.5f ? wi : wo, u0, u1, u2);
    const float p = nbPhaseEval(v.phase, dot(wi, w)), q = 0.5f * (p + nbPhaseEval(v.phase, dot(w, wo)));
    if (!(q > 0.0f) || !medium.span(v.origin, w, 0.0f, casterDistance(ps, v.origin, w), v.t0, v.t1))
        return false;
    v.dir = w;
    v.flux = v.flux * (p / q);
    return true;
}

// The point the cache is projected toward: the camera's eye at the shutter's centre (the origin
// of the camera rays, as marchOrders3 requires), unless the options set one.
float3 viewerOf(const RenderContext& ctx, const Orders3Options& options)
{
    if (options.hasViewer || !ctx.scene)
        return options.viewer;
    return CameraLattice(ctx.scene->camera, 1).eye();
}

// The image's camera samples: pixels x spp (the scene's, or the march's default).
double cameraSamples(const Scene& scene)
{
    const double spp = scene.render.spp > 0 ? scene.render.spp : kDefaultMarchSpp;
    return double(std::max(1, scene.camera.width)) * double(std::max(1, scene.camera.height)) * spp;
}

// The adaptive count's pilot camera rays: a lattice of pixel centres over the image (at most
// kPilotSide on its longer side, at mid-shutter) and each ray's L0 + L1 per channel, marchSingle's,
// the part of the pixel the cache's noise is measured against.
struct PilotRays {
    std::vector<float3> o, d;
    std::vector<float> base;  // [ray][rgb]
};

PilotRays pilotRays(const RenderContext& ctx)
{
    PilotRays p;
    if (!ctx.scene)
        return p;
    const Camera& cam = ctx.scene->camera;
    const CameraLattice lattice(cam, std::min(kPilotSide, std::max(cam.width, cam.height)));
    for (int py = 0; py < lattice.ny; ++py)
        for (int px = 0; px < lattice.nx; ++px) {
            float3 o, d;
            lattice.ray(px, py, o, d);
            p.o.push_back(o);
            p.d.push_back(d);
        }
    const size_t n = p.o.size();
    p.base.assign(3 * n, 0.0f);
    const size_t stride = 3 * ctx.lights.size();
    tbb::parallel_for(size_t(0), n, [&](size_t r) {
        throwIfStopped(&ctx.stop);
        std::vector<float> perLight(stride, 0.0f);
        NbRng rng = nbRngStart(kPilotKey, uint32_t(r), 0u);
        CameraSample s;
        marchSingle(ctx, p.o[r], p.d[r], rng, s, perLight.data());
        const Rgb L = s.L0 + s.L1;
        p.base[3 * r + 0] = L.x, p.base[3 * r + 1] = L.y, p.base[3 * r + 2] = L.z;
    });
    return p;
}

// The relMSE the cache's noise adds to the image, as the validation suite measures an image's
// (the mean over pixels and channels of e^2 / (v^2 + eps), eps = (0.1 mean v)^2), from two
// independent half estimates a and b of the cache (each from half the paths, scaled by 2): their
// mean's variance at a pixel is ((A - B) / 2)^2 in expectation, A and B what the pilot ray reads
// from each, v the pixel's L0 + L1 + (A + B) / 2. Order 2 is left out of v: the estimate errs
// high. Its standard error from the spread of the pilots' own terms (each the mean of its three
// channels': the channels of a pixel are not independent).
struct NoiseEstimate {
    double mean = 0.0, stdErr = 0.0;
};

NoiseEstimate cacheNoise(const RenderContext& ctx, const PilotRays& pilots, const wkb::RadianceGrid& a,
                         const wkb::RadianceGrid& b)
{
    const size_t n = pilots.o.size();
    if (n == 0)
        return {};
    const float step = ctx.scene ? ctx.scene->render.step : 0.5f;
    std::vector<double> e2(3 * n, 0.0), v(3 * n, 0.0);
    tbb::parallel_for(size_t(0), n, [&](size_t r) {
        throwIfStopped(&ctx.stop);
        // The same quadrature through both halves: their difference is the cache's alone.
        const float jitter = 0.5f;
        const float3 A = wkb::marchOrders3(ctx.volumes, a, pilots.o[r], pilots.d[r], INFINITY,
                                           0.0f, jitter, step, wkb::kOrders3StepScale);
        const float3 B = wkb::marchOrders3(ctx.volumes, b, pilots.o[r], pilots.d[r], INFINITY,
                                           0.0f, jitter, step, wkb::kOrders3StepScale);
        const float dA[3] = {A.x, A.y, A.z}, dB[3] = {B.x, B.y, B.z};
        for (int c = 0; c < 3; ++c) {
            const double diff = 0.5 * (double(dA[c]) - double(dB[c]));
            e2[3 * r + c] = diff * diff;
            v[3 * r + c] = double(pilots.base[3 * r + c]) + 0.5 * (double(dA[c]) + double(dB[c]));
        }
    });
    double mean = 0.0;
    for (double x : v)
        mean += x;
    mean /= double(v.size());
    const double eps = std::max((0.1 * mean) * (0.1 * mean), 1e-20);
    NoiseEstimate out;
    std::vector<double> term(n, 0.0);
    for (size_t r = 0; r < n; ++r) {
        for (size_t c = 0; c < 3; ++c)
            term[r] += e2[3 * r + c] / (v[3 * r + c] * v[3 * r + c] + eps) / 3.0;
        out.mean += term[r] / double(n);
    }
    double ss = 0.0;
    for (double t : term)
        ss += (t - out.mean) * (t - out.mean);
    out.stdErr = n > 1 ? std::sqrt(ss / double(n - 1) / double(n)) : 0.0;
    return out;
}

}  // namespace

int orders3GridCells(const RenderContext& ctx)
{
    const int fixed = ctx.scene ? ctx.scene->render.wkbOrders3Grid : 0;
    if (fixed > 0)
        return fixed;
    const Bbox box = ctx.volumes.worldBounds();
    const double longest = std::max({double(box.hi.x - box.lo.x), double(box.hi.y - box.lo.y), double(box.hi.z - box.lo.z)});
    if (!(longest > 0.0))
        return kGridCells;
    const double cell = longest / double(kGridCells);
    double want = double(kGridCells);
    for (const auto& v : ctx.volumes.volumes()) {
        const Rgb st = v->sigmaT(), ss = v->sigmaS();
        const double g = double(nbPhaseMeanCos(v->medium.phase)), density = double(v->density.maxValue());
        for (int c = 0; c < 3; ++c) {
            const double t = double((&st.x)[c]) * density;
            const double omega = double((&st.x)[c]) > 0.0 ? std::min(1.0, double((&ss.x)[c]) / double((&st.x)[c])) : 1.0;
            const double transport = cell * t * (1.0 - g * omega);  // the cell in transport mean free paths
            const double diffusion = cell * t * std::sqrt(std::max(0.0, 3.0 * (1.0 - omega) * (1.0 - g * omega)));
            if (skinCellScale(transport, diffusion))
                continue;  // skin cells where the camera sees such a medium
            want = std::max(want, std::ceil(double(kGridCells) * transport / kMaxCellTransportLengths));
        }
    }
    return int(std::min(want, double(kMaxGridCells)));
}

long long orders3PathCap(const Scene& scene)
{
    const RenderSettings& r = scene.render;
    if (r.wkbOrders3Paths > 0)
        return r.wkbOrders3Paths;
    const double p = kPathCapPerSample * std::sqrt(cameraSamples(scene));
    return (long long)std::llround(std::clamp(p, 65536.0, double(1 << 24)));
}

size_t orders3FillBytes(const RenderContext& ctx, const Orders3Options& options)
{
    if (ctx.volumes.empty() || (options.paths <= 0 && options.maxPaths <= 0))
        return 0;
    const size_t cells = wkb::RadianceGrid::cellCountFor(ctx.volumes.worldBounds(), 0.0f, options.maxCells);
    size_t worst = 0;  // over the layer counts traceOrders3 can choose: the grid plus its partials
    for (int layers = 1; layers <= std::max(1, int(ctx.lights.size())); ++layers)
        // The grid and its partials, and while the adaptive count measures the noise a second
        // half grid and the blur's buffer.
        worst = std::max(worst, size_t(layers) * size_t((options.paths > 0 ? 1 : 3) + std::max(2, kPartials / layers)));
    return cells * size_t(wkb::RadianceGrid::kFloats) * sizeof(float) * worst + skinCellsBytes(cells);
}

std::shared_ptr<const wkb::RadianceGrid> traceOrders3(const RenderContext& ctx, const Orders3Options& options,
                                                      Orders3Report* report)
{
    if (ctx.volumes.empty() || (options.paths <= 0 && options.maxPaths <= 0))
        return nullptr;
    PathtraceScene ps = buildPathtraceScene(ctx);
    const VrlMedium medium(ps, false);  // free flights only: no slot minorants
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
    // A read reaches one cell past the medium, and each blur pass one more.
    const std::vector<uint8_t> reach = cellReach(ctx.volumes, *grid, 1 + kBlurPasses);
    const ViewerPhase phase{viewerOf(ctx, options), PhaseMix::phasesOf(ctx)};
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
    const size_t floats = grid->data().size();
    // Fewer partial grids with more layers: the partials' memory stays that of kPartials one-layer
    // grids (a fixed count for a scene: deterministic).
    const int partials = std::max(2, kPartials / grid->layers());
    // Each allocated (and its pages first touched) by the task that fills it.
    std::vector<std::vector<float>> partial{size_t(partials)};
    // Batches [b0, b1) of `paths` light paths each (the grid is divided by the batch count at the
    // end), traced and deposited as they go: partial p takes the paths [p, p + 1) paths / partials
    // of every batch, in one task, so what each partial holds is fixed whatever the thread count,
    // no segment list is kept, and the halves of the partials hold independent halves of the
    // paths (the adaptive count's noise). At most `partials` threads work.
    auto traceBatches = [&](long long b0, long long b1, int paths) {
        tbb::parallel_for(0, partials, [&](int p) {
            if (partial[size_t(p)].empty())
                partial[size_t(p)].assign(floats, 0.0f);
            std::vector<Vrl> path;
            const int lo = int((long long)paths * p / partials), hi = int((long long)paths * (p + 1) / partials);
            for (long long b = b0; b < b1; ++b)
                for (int i = lo; i < hi; ++i) {
                    // A stopped render (RenderControl.h): the paths end early, the deposits stop
                    // within a few hundred paths, and the grid is dropped with the render.
                    if ((i - lo) % kStopPollInterval == kStopPollInterval - 1)
                        throwIfStopped(&ctx.stop);
                    path.clear();
                    pass.tracePath(options.seed, uint32_t(b), i, paths, path);
                    // The deposits' stream, keyed by the path's number over all batches (the
                    // path's own is keyed by (path, batch) under another seed).
                    NbRng rng = nbRngStart(nbPcgHash(options.seed ^ kDepositKey), uint32_t(b * (long long)paths + i),
                                           kDepositKey);
                    for (size_t j = 0; j < path.size(); ++j) {
                        Vrl v = path[j];
                        if (v.order < options.firstOrder)
                            continue;
                        // A path's segments are consecutive, in order (LightPass::tracePath): the
                        // one before a segment that leaves a scattering vertex arrived there.
                        const bool vertex = v.order >= 1 && j > 0 && path[j - 1].order == v.order - 1;
                        if (options.aimDeposits && vertex &&
                            !aimDeposit(ps, medium, phase.viewer, path[j - 1].dir, v, rng))
                            continue;
                        deposit(ctx, *grid, skin, phase, reach, v, layerOf[size_t(v.light)], h, rng,
                                partial[size_t(p)].data());
                    }
                }
        });
        throwIfStopped(&ctx.stop);
    };
    // The cache from partials [p0, p1) over `batches` batches, scaled by `gain`, into `out`
    // (the grid's shape): their sum, the skin cells resolved (scratch: a buffer, which may be a
    // partial once they are summed).
    auto finish = [&](int p0, int p1, long long batches, float gain, wkb::RadianceGrid& out,
                      std::vector<float>& scratch) {
        std::vector<float>& data = out.data();
        std::fill(data.begin(), data.end(), 0.0f);
        for (int p = p0; p < p1; ++p)
            for (size_t i = 0; i < floats; ++i)
                data[i] += partial[size_t(p)][i];
        const float scale = gain / float(batches);
        for (float& v : data)
            v *= scale;
        resolveSkinCells(skin, out, scratch);
    };
    auto smooth = [&](wkb::RadianceGrid& out, std::vector<float>& scratch) {
        for (int k = 0; k < kBlurPasses; ++k)
            blur(out, skin, scratch, ctx.stop);
    };

    long long batches = 0;
    bool blurred = true;  // the finished cache blurred (kBlurPasses)
    if (options.paths > 0) {
        const long long n = (options.paths + kBatch - 1) / kBatch;
        const int perBatch = int((options.paths + n - 1) / n);
        traceBatches(0, n, perBatch);
        batches = n;
        if (report)
            report->paths = n * perBatch;
    } else {
        // The adaptive count (docs/wkb.md "How many light paths"): a first round, then the count
        // the cache's measured noise asks for. Each half of the partials holds half of every
        // batch's segments, an independent estimate of the cache; pilot rays read both halves, and
        // their difference gives A, the relMSE the cache adds to the image times its paths.
        const long long cap = std::max<long long>(kBatch, options.maxPaths);
        const double samples = ctx.scene ? cameraSamples(*ctx.scene) : 1.0;
        const PilotRays pilots = pilotRays(ctx);
        wkb::RadianceGrid half = *grid;  // the shape; the data is overwritten
        std::vector<float> scratch;
        long long target = std::min(cap, kFirstRoundPaths);
        NoiseEstimate noise{-1.0, 0.0};
        long long noisePaths = 0;  // the paths at which `noise` was measured
        for (int round = 0;; ++round) {
            const long long need = (target + kBatch - 1) / kBatch;
            if (need > batches) {
                traceBatches(batches, need, int(kBatch));
                batches = need;
            }
            const long long traced = batches * kBatch;
            if (traced >= cap || round + 1 == kMaxRounds)
                break;
            finish(0, partials / 2, batches, 2.0f, *grid, scratch);
            finish(partials / 2, partials, batches, 2.0f, half, scratch);
            // The count the noise asks for: enough that the cache's noise is under
            // kCacheNoiseTarget, and the count that makes error x time least where the march's
            // time grows with the camera's samples; a round whenever that is more than traced (a
            // margin of 25% that skipped smaller rounds let the first round's estimate, low where
            // the noise is heavy-tailed, stop a dense core at 0.0100: docs/validation.md
            // "Deposits aimed at the camera").
            auto pathsFor = [&](double measured) {
                const double A = measured * double(traced);
                const double want = std::max(A / kCacheNoiseTarget, kBalance * std::sqrt(A * samples));
                return want <= double(traced) ? traced : std::min<long long>(cap, (long long)std::ceil(want));
            };
            NoiseEstimate sharp{-1.0, 0.0};
            if (round == 0 || !blurred)
                sharp = cacheNoise(ctx, pilots, *grid, half);
            // Where the sharp cache asks for no more paths, within the cap, the blur cannot be
            // chosen below (pathsFor is at least `traced`): its estimate is not needed.
            const bool sharpOverCap = sharp.mean * double(traced) / kCacheNoiseTarget > double(cap);
            const bool sharpSuffices = round == 0 && !sharpOverCap && pathsFor(sharp.mean) == traced;
            if (!sharpSuffices && (round == 0 || blurred)) {
                smooth(*grid, scratch);
                smooth(half, scratch);
                noise = cacheNoise(ctx, pilots, *grid, half);
            }
            if (round == 0)
                // The blur trades the cache's noise for a bias where the light changes within a
                // cell (a lit face): it is left out where the sharp cache asks for no more paths
                // than the blurred one and meets the target within the cap. Only there: the sharp
                // cache's noise is heavy-tailed (a few bright paths), and a count extrapolated from
                // it falls short (at 256x256 a sunlit cumulus's, 0.048 at 65536 paths, was 0.048
                // again at 1.6 M).
                blurred = !sharpSuffices && (sharpOverCap || pathsFor(sharp.mean) > pathsFor(noise.mean));
            if (!blurred)
                noise = sharp;
            noisePaths = traced;
            target = pathsFor(noise.mean);
            if (target <= traced)
                break;
        }
        if (report) {
            report->paths = batches * kBatch;
            report->adaptive = true;
            report->blurred = blurred;
            report->noiseMeasured = noise.mean;
            report->noiseStdErr = noise.stdErr;
            report->noisePaths = noisePaths;
        }
    }
    throwIfStopped(&ctx.stop);
    finish(0, partials, batches, 1.0f, *grid, partial[0]);
    if (blurred)
        smooth(*grid, partial[0]);
    return grid;
}

}  // namespace nimbus::vrl
