#include "SkinCells.h"

#include "../core/StepCount.h"
#include "CameraLattice.h"
#include "PhaseMixture.h"
#include "../single/ScatterPoints.h"
#include "../scene/KernelScene.h"

#include <algorithm>
#include <cmath>

namespace nimbus::vrl {

namespace {

// Camera rays of the skin pass: spaced at most half a cell apart where the grid is nearest to
// the camera (so that each cell's denominator is the integral over its own cross-section, not
// a neighbour's), within these bounds along the image's longer side.
constexpr int kMinRays = 16, kMaxRays = 256;
// A cell is a skin cell only if the pass's rays crossed its neighbourhood (kSkinRadius cells each
// side) at least this many times: where they are sparser (near a camera inside or close to the
// grid, past kMaxRays) the integrals alias with the ray spacing, and the cell keeps its volume mean.
constexpr int kMinRaysPerHood = 8;
// Where the camera's transmittance is below this the skin pass's rays and the point marches stop.
constexpr float kMinTransmittance = 1e-4f;
// The largest optical depth of one step of those marches (as StiffVoxels' sub-steps).
constexpr float kStepDepth = 0.5f;

// The per-cell integrals of the skin pass (each ray's weighted by t^2 dOmega): sigma_s T_cam per
// channel, and grey sigma_t T_cam, sigma_s T_cam and g sigma_s T_cam; and the largest grey
// extinction a ray sampled there.
enum { kDr, kDg, kDb, kSt, kSs, kSg, kStMax, kAcc };

}  // namespace

int skinSubSteps(const VolumeSet& volumes, float3 o, float3 d, float len)
{
    float st = 0.0f;
    for (int k = 0; k <= 2; ++k) {
        const Rgb s = volumes.sample(o + d * (0.5f * float(k) * len)).sigma_t;
        st = std::fmax(st, std::fmax(s.x, std::fmax(s.y, s.z)));
    }
    const float depth = st * len;
    return depth > kStepDepth ? std::min(4096, int(std::ceil(depth / kStepDepth))) : 1;
}

namespace {

// The sub-steps of o + t d, t in [0, tMax], over the volumes' spans: each span's steps, each cut
// into skinSubSteps pieces of at most kStepDepth optical depth; f(tMid, ds) per piece, in order,
// until f returns false. The camera pass and cameraTransmittance march alike through it. spans:
// the caller's scratch.
template <class F>
void forEachSubStep(const VolumeSet& volumes, float3 o, float3 d, float tMax, std::vector<Span>& spans, F&& f)
{
    volumes.spans(o, d, 0.0f, tMax, 1.0f, spans);
    for (const Span& sp : spans) {
        const float len = sp.t1 - sp.t0;
        const int n = stepCount(len, sp.step);
        const float dt = len / float(n);
        for (int k = 0; k < n; ++k) {
            const float ta = sp.t0 + float(k) * dt;
            const int m = skinSubSteps(volumes, o + d * ta, d, dt);
            const float ds = dt / float(m);
            for (int i = 0; i < m; ++i)
                if (!f(ta + (float(i) + 0.5f) * ds, ds))
                    return;
        }
    }
}

}  // namespace

size_t skinCellsBytes(size_t cells)
{
    // The integrals, their neighbourhood sums and the sums' scratch; the ray counts, their sums and
    // scratch; the slots; the skin cells' denominators (at most every cell).
    return cells * (3 * size_t(kAcc) * sizeof(double) + sizeof(uint8_t) + 2 * sizeof(uint32_t) + sizeof(int) +
                    3 * sizeof(float));
}

Rgb cameraTransmittance(const VolumeSet& volumes, float3 x, float3 camera)
{
    thread_local std::vector<Span> spans;
    const float3 toCamera = camera - x;
    const float dist = length(toCamera);
    if (!(dist > 0.0f))
        return splat(1.0f);
    const float3 d = toCamera * (1.0f / dist);
    const float tauMax = -std::log(kMinTransmittance);
    Rgb tau = splat(0.0f);
    bool dark = false;
    forEachSubStep(volumes, x, d, dist, spans, [&](float t, float ds) {
        tau += volumes.sample(x + d * t).sigma_t * ds;
        dark = std::fmin(tau.x, std::fmin(tau.y, tau.z)) > tauMax;
        return !dark;
    });
    return dark ? splat(0.0f) : make_float3(std::exp(-tau.x), std::exp(-tau.y), std::exp(-tau.z));
}

SkinCells findSkinCells(const RenderContext& ctx, const wkb::RadianceGrid& grid)
{
    SkinCells skin;
    if (!ctx.scene || grid.empty())
        return skin;
    {
        // No pass where no cell can be a skin cell: the cell's size over the shortest diffusion
        // and transport lengths the media allow (the densest extinction of all volumes together, and
        // the lowest albedo and mean cosine of any) is under both thresholds. Most clouds stop here.
        double sigmaT = 0.0, absorb = 0.0, transport = 0.0;
        for (const auto& v : ctx.volumes.volumes()) {
            const Rgb st = v->sigmaT(), ss = v->sigmaS();
            sigmaT += double(nbMaxComponent(st)) * double(v->density.maxValue());
            const double g = double(nbPhaseMeanCos(v->medium.phase));
            transport = std::max(transport, 1.0 - std::min(g, 0.0));  // the largest 1 - g omega
            for (int c = 0; c < 3; ++c) {
                const double t = double((&st.x)[c]), omega = t > 0.0 ? std::min(1.0, double((&ss.x)[c]) / t) : 1.0;
                absorb = std::max(absorb, 3.0 * (1.0 - omega) * (1.0 - std::min(g, 0.0) * omega));
            }
        }
        const double cellTau = double(grid.cellSize()) * sigmaT;
        if (!skinCellScale(cellTau * transport, cellTau * std::sqrt(absorb)))
            return skin;
    }
    const Camera& cam = ctx.scene->camera;
    const CameraLattice view(cam, 1);  // for its camera; the rays' lattice is sized below
    const NbCamera& nc = view.nc;
    const int W = view.W, H = view.H;
    const float shutter = CameraLattice::kShutter;
    {
        float3 f, dr, du;
        view.rayAt(0.5f * float(W), 0.5f * float(H), skin.camera, f);
        view.rayAt(float(W), 0.5f * float(H), skin.camera, dr);
        view.rayAt(0.5f * float(W), 0.0f, skin.camera, du);
        // d / (d . f) - f reaches the image's edge at the edge's ray: scaled by its squared length,
        // dot(v, right) / dot(v, f) is 1 there.
        const float3 er = dr * (1.0f / dot(dr, f)) - f, eu = du * (1.0f / dot(du, f)) - f;
        skin.forward = f;
        skin.right = er * (1.0f / dot(er, er));
        skin.up = eu * (1.0f / dot(eu, eu));
    }
    const double tanHalf = double(nbCameraTanHalfFov(nc, shutter));
    const double aspect = double(W) / double(H);
    int rays = kMaxRays;  // along the longer side
    {
        // The distance from the camera to the grid's box (0 inside it), and the image's width there.
        const Bbox& b = grid.box();
        const float3 c = skin.camera, q = fmin(fmax(c, b.lo), b.hi);
        const double near = std::max(double(length(c - q)), double(grid.cellSize()));
        const double width = 2.0 * near * tanHalf * std::max(aspect, 1.0);
        rays = int(std::clamp(std::ceil(2.0 * width / double(grid.cellSize())), double(kMinRays), double(kMaxRays)));
    }
    const CameraLattice lattice(cam, rays);
    const int nx = lattice.nx, ny = lattice.ny;
    // Each ray's share of the image plane at distance 1 (2 tan(fov/2) aspect by 2 tan(fov/2)).
    const double planeArea = (2.0 * tanHalf * aspect) * (2.0 * tanHalf) / (double(nx) * double(ny));
    const float3 axis = nbCameraViewAxis(nc, shutter);

    const size_t cells = grid.cellCount();
    std::vector<double> acc(cells * kAcc, 0.0);
    std::vector<uint8_t> crossed(cells, 0);  // rays that crossed each cell, saturating
    const float3 lo = grid.box().lo;
    const float inv = 1.0f / grid.cellSize();
    auto cellOf = [&](float3 p) -> long {
        const float3 u = (p - lo) * inv;
        const int i = int(std::floor(u.x)), j = int(std::floor(u.y)), k = int(std::floor(u.z));
        if (i < 0 || j < 0 || k < 0 || i >= grid.size(0) || j >= grid.size(1) || k >= grid.size(2))
            return -1;
        return long((size_t(k) * size_t(grid.size(1)) + size_t(j)) * size_t(grid.size(0)) + size_t(i));
    };
    const std::vector<NbPhase> phases = PhaseMix::phasesOf(ctx);
    std::vector<float> pw(phases.size(), 0.0f);
    std::vector<Span> spans;
    for (int py = 0; py < ny; ++py) {
        throwIfStopped(&ctx.stop);
        for (int px = 0; px < nx; ++px) {
            float3 o, d;
            lattice.ray(px, py, o, d);
            // The ray's solid angle: its share of the plane times cos^3 of its angle to the axis.
            const double cosA = std::fabs(double(dot(d, axis)));
            const double dOmega = planeArea * cosA * cosA * cosA;
            double T[3] = {1, 1, 1};
            long lastCell = -1;
            forEachSubStep(ctx.volumes, o, d, 1e30f, spans, [&](float tm, float ds) {
                const float3 x = o + d * tm;
                std::fill(pw.begin(), pw.end(), 0.0f);
                const MediumSample s = ctx.volumes.sample(x, pw.data());
                const double st[3] = {s.sigma_t.x, s.sigma_t.y, s.sigma_t.z};
                const double ss[3] = {s.sigma_s.x, s.sigma_s.y, s.sigma_s.z};
                double I[3];  // int T_cam over the sub-step
                for (int c = 0; c < 3; ++c) {
                    const double y = st[c] * double(ds);
                    I[c] = T[c] * (y > 1e-6 ? -std::expm1(-y) / st[c] : double(ds) * (1.0 - 0.5 * y));
                    T[c] *= std::exp(-y);
                }
                const long cell = cellOf(x);
                if (cell >= 0) {
                    if (cell != lastCell && crossed[size_t(cell)] < 255)
                        ++crossed[size_t(cell)];
                    lastCell = cell;
                    const double g = mixedMeanCosine(phases, pw.data());
                    const double w = dOmega * double(tm) * double(tm);
                    double* a = acc.data() + size_t(cell) * kAcc;
                    double ssI = 0.0;
                    for (int c = 0; c < 3; ++c) {
                        a[kDr + c] += w * ss[c] * I[c];
                        a[kSt] += w * st[c] * I[c] / 3.0;
                        ssI += ss[c] * I[c] / 3.0;
                    }
                    a[kSs] += w * ssI;
                    a[kStMax] = std::max(a[kStMax], (st[0] + st[1] + st[2]) / 3.0);
                    a[kSg] += w * g * ssI;
                }
                return std::max(T[0], std::max(T[1], T[2])) >= double(kMinTransmittance);
            });
        }
    }
    // The classification reads each cell's neighbourhood (kSkinRadius cells each side, the
    // resolve's): rays sample a cell's cross-section at points, so one cell's own integrals
    // alias with the ray spacing, and its neighbourhood's do not (box sums, axis by axis).
    std::vector<double> hood = acc;
    std::vector<uint32_t> hoodRays(crossed.begin(), crossed.end());
    {
        const int n[3] = {grid.size(0), grid.size(1), grid.size(2)};
        const size_t stride[3] = {1, size_t(n[0]), size_t(n[0]) * size_t(n[1])};
        std::vector<double> tmp;
        std::vector<uint32_t> tmpRays;
        for (int axis = 0; axis < 3; ++axis) {
            tmp = hood;
            tmpRays = hoodRays;
            for (size_t c = 0; c < cells; ++c) {
                const int i = int((c / stride[axis]) % size_t(n[axis]));
                double sum[kAcc] = {};
                uint32_t rays = 0;
                for (int o = -kSkinRadius; o <= kSkinRadius; ++o) {
                    if (i + o < 0 || i + o >= n[axis])
                        continue;
                    const size_t q = size_t(long(c) + long(o) * long(stride[axis]));
                    for (int k = 0; k < kAcc; ++k)
                        sum[k] = k == kStMax ? std::max(sum[k], tmp[q * kAcc + size_t(k)]) : sum[k] + tmp[q * kAcc + size_t(k)];
                    rays += tmpRays[q];
                }
                std::copy(sum, sum + kAcc, hood.begin() + long(c * kAcc));
                hoodRays[c] = rays;
            }
        }
    }
    skin.slot.assign(cells, -1);
    for (size_t c = 0; c < cells; ++c) {
        const double* a = hood.data() + c * kAcc;
        if (hoodRays[c] < uint32_t(kMinRaysPerHood) || !(a[kSt] > 0.0) ||
            !(a[kDr] > 0.0 || a[kDg] > 0.0 || a[kDb] > 0.0))
            continue;
        const double sigmaT = a[kStMax];  // the medium under the face, not the ramp the camera sees into
        const double omega = std::min(1.0, a[kSs] / a[kSt]);
        const double g = a[kSs] > 0.0 ? a[kSg] / a[kSs] : 0.0;
        const double cellTau = double(grid.cellSize()) * sigmaT;
        if (!skinCellScale(cellTau * (1.0 - g * omega),
                           cellTau * std::sqrt(std::max(1e-12, 3.0 * (1.0 - omega) * (1.0 - g * omega)))))
            continue;
        skin.slot[c] = int(skin.count());
        for (int k = 0; k < 3; ++k)
            skin.weight.push_back(float(acc[c * kAcc + size_t(kDr + k)]));
    }
    if (skin.count() == 0)
        skin.slot.clear();
    return skin;
}

void SkinPoint::offer(float t0, float dt, const float rT[3], Rgb sigmaS, Rgb sigmaT, float u)
{
    // The step's weight: the grey mean of sigma_s int r T dt over it.
    const float st[3] = {sigmaT.x, sigmaT.y, sigmaT.z}, ss[3] = {sigmaS.x, sigmaS.y, sigmaS.z};
    float q = 0.0f;
    for (int c = 0; c < 3; ++c) {
        const float x = st[c] * dt;
        q += ss[c] * rT[c] * (x > 1e-4f ? -std::expm1(-x) / st[c] : dt * (1.0f - 0.5f * x)) / 3.0f;
    }
    if (!(q > 0.0f))
        return;
    mTotal += double(q);
    if (double(u) * mTotal < double(q)) {
        mT0 = t0;
        mDt = dt;
        mQ = q;
        for (int c = 0; c < 3; ++c)
            mRT[c] = rT[c];
        mSigmaS = sigmaS;
        mSigmaT = sigmaT;
    }
}

float3 SkinPoint::draw(float3 o, float3 d, float u, float estimate[3]) const
{
    // Within the step, density s e^{-s x} / (1 - e^{-s dt}) on [0, dt], s the grey extinction:
    // pdf(t) = (q / total) s e^{-s x} / (1 - e^{-s dt}).
    const float s = (mSigmaT.x + mSigmaT.y + mSigmaT.z) / 3.0f;
    const float y = s * mDt;
    float x, density;
    if (y > 1e-4f) {
        x = -std::log1p(u * std::expm1(-y)) / s;
        x = std::fmin(std::fmax(x, 0.0f), mDt);
        density = s * std::exp(-s * x) / -std::expm1(-y);
    } else {
        x = u * mDt;
        density = 1.0f / mDt;
    }
    const float pdf = float(double(mQ) / mTotal) * density;
    const float st[3] = {mSigmaT.x, mSigmaT.y, mSigmaT.z}, ss[3] = {mSigmaS.x, mSigmaS.y, mSigmaS.z};
    for (int c = 0; c < 3; ++c)
        estimate[c] = ss[c] * mRT[c] * std::exp(-st[c] * x) / pdf;
    return o + d * (mT0 + x);
}

void resolveSkinCells(const SkinCells& skin, wkb::RadianceGrid& grid, std::vector<float>& scratch)
{
    if (skin.count() == 0)
        return;
    const size_t F = size_t(grid.floatsPerCell());
    const int n0 = grid.size(0), n1 = grid.size(1), n2 = grid.size(2);
    std::vector<float>& data = grid.data();
    auto index = [&](int x, int y, int z) { return (size_t(z) * size_t(n1) + size_t(y)) * size_t(n0) + size_t(x); };
    scratch.assign(skin.count() * F, 0.0f);
    std::vector<double> num(F);
    for (int z = 0; z < n2; ++z)
        for (int y = 0; y < n1; ++y)
            for (int x = 0; x < n0; ++x) {
                const int self = skin.slot[index(x, y, z)];
                if (self < 0)
                    continue;
                std::fill(num.begin(), num.end(), 0.0);
                double den[3] = {0, 0, 0};
                for (int dz = -kSkinRadius; dz <= kSkinRadius; ++dz)
                    for (int dy = -kSkinRadius; dy <= kSkinRadius; ++dy)
                        for (int dx = -kSkinRadius; dx <= kSkinRadius; ++dx) {
                            const int X = x + dx, Y = y + dy, Z = z + dz;
                            if (X < 0 || Y < 0 || Z < 0 || X >= n0 || Y >= n1 || Z >= n2)
                                continue;
                            const size_t cell = index(X, Y, Z);
                            const int sl = skin.slot[cell];
                            if (sl < 0)
                                continue;
                            const double w = double((kSkinRadius + 1 - std::abs(dx)) * (kSkinRadius + 1 - std::abs(dy)) *
                                                    (kSkinRadius + 1 - std::abs(dz)));
                            for (size_t k = 0; k < F; ++k)
                                num[k] += w * double(data[cell * F + k]);
                            for (int c = 0; c < 3; ++c)
                                den[c] += w * double(skin.weight[size_t(sl) * 3 + size_t(c)]);
                        }
                for (size_t k = 0; k < F; ++k)
                    scratch[size_t(self) * F + k] = den[k % 3] > 0.0 ? float(num[k] / den[k % 3]) : 0.0f;
            }
    for (size_t cell = 0; cell < skin.slot.size(); ++cell)
        if (skin.slot[cell] >= 0)
            std::copy_n(scratch.data() + size_t(skin.slot[cell]) * F, F, data.data() + cell * F);
}

}  // namespace nimbus::vrl
