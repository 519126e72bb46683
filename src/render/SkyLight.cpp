#include "SkyLight.h"

#include "../core/StepCount.h"

#include "../geometry/EmbreeScene.h"
#include "SphericalHarmonics.h"
#include "VolumeSet.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace nimbus {

namespace {

// One cell of the sphere: its texels' exact sum of y_jm(n') L dOmega (n' = -w, the direction
// the light travels; RGB innermost) and the direction its shadow rays take.
struct Cell {
    std::vector<double> E;
    std::vector<float> Epad;  // E as a grid node lays it out (SkyLight::Grid::stride)
    float3 towardLight;
};

std::vector<Cell> makeCells(const EnvironmentMap& map, Rgb colour, int order)
{
    const int W = map.width(), H = map.height(), count = shCount(order);
    const int rows = std::min(H, SkyLight::kCellRows), cols = std::min(W, SkyLight::kCellColumns);
    std::vector<Cell> cells(size_t(rows * cols));
    std::vector<double> weight(cells.size(), 0.0);
    std::vector<double> mean(cells.size() * 3, 0.0);  // radiance-weighted sum of directions
    for (Cell& c : cells)
        c.E.assign(size_t(3 * count), 0.0);
    std::vector<double> y(static_cast<size_t>(count));
    for (int j = 0; j < H; ++j) {
        const double dOmega = map.texelSolidAngle(j);
        const int cr = j * rows / H;
        for (int i = 0; i < W; ++i) {
            const Rgb L = map.texel(i, j) * colour;
            const double lum = (double(L.x) + L.y + L.z) / 3.0;
            if (!(lum > 0.0))
                continue;
            const size_t k = size_t(cr * cols + i * cols / W);
            const float3 w = map.texelDirection(i, j);
            shEvaluate(order, -w, y.data());
            for (int jm = 0; jm < count; ++jm) {
                cells[k].E[3 * jm + 0] += y[jm] * L.x * dOmega;
                cells[k].E[3 * jm + 1] += y[jm] * L.y * dOmega;
                cells[k].E[3 * jm + 2] += y[jm] * L.z * dOmega;
            }
            weight[k] += lum * dOmega;
            mean[3 * k + 0] += lum * dOmega * w.x;
            mean[3 * k + 1] += lum * dOmega * w.y;
            mean[3 * k + 2] += lum * dOmega * w.z;
        }
    }
    std::vector<Cell> out;
    for (size_t k = 0; k < cells.size(); ++k) {
        if (!(weight[k] > 0.0))
            continue;  // a black part of the sky sends no light: no shadow ray
        // As the grid's nodes lay coefficients out (SkyLight::Grid): RGB and a zero per jm, count
        // rounded up to even.
        cells[k].Epad.assign(size_t(4 * ((count + 1) & ~1)), 0.0f);
        for (int jm = 0; jm < count; ++jm)
            for (int ch = 0; ch < 3; ++ch)
                cells[k].Epad[size_t(4 * jm + ch)] = float(cells[k].E[size_t(3 * jm + ch)]);
        float3 m = make_float3(float(mean[3 * k]), float(mean[3 * k + 1]), float(mean[3 * k + 2]));
        const float len = length(m);
        if (len > 1e-6f * float(weight[k])) {
            m = m / len;
        } else {  // a cell whose directions cancel (a whole-sphere cell of a tiny map): its centre
            const int cr = int(k) / cols, cc = int(k) % cols;
            m = nbEnvDirection(map.header(), (cc + 0.5f) / cols, (cr + 0.5f) / rows);
        }
        cells[k].towardLight = m;
        out.push_back(std::move(cells[k]));
    }
    return out;
}

// The sky as point sources for the phase tail (SkyLight::tailAlong): blocks of at most 64 x 32
// of the map's texels, each its summed L dOmega at its radiance-weighted mean direction.
struct SkySource {
    float3 w;
    Rgb LdOmega;
    float dOmega;
};
std::vector<SkySource> skySources(const EnvironmentMap& map, Rgb colour)
{
    const int W = map.width(), H = map.height();
    const int bx = (W + 63) / 64, by = (H + 31) / 32;
    std::vector<SkySource> out;
    for (int j0 = 0; j0 < H; j0 += by)
        for (int i0 = 0; i0 < W; i0 += bx) {
            double L[3] = {0, 0, 0}, m[3] = {0, 0, 0}, omega = 0;
            for (int j = j0; j < std::min(H, j0 + by); ++j)
                for (int i = i0; i < std::min(W, i0 + bx); ++i) {
                    const double dOmega = map.texelSolidAngle(j);
                    const Rgb t = map.texel(i, j) * colour;
                    const float3 w = map.texelDirection(i, j);
                    const double lum = (std::fabs(t.x) + std::fabs(t.y) + std::fabs(t.z)) * dOmega + 1e-30 * dOmega;
                    L[0] += t.x * dOmega, L[1] += t.y * dOmega, L[2] += t.z * dOmega;
                    omega += dOmega;
                    m[0] += lum * w.x, m[1] += lum * w.y, m[2] += lum * w.z;
                }
            const double len = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
            if (!(len > 0.0))
                continue;
            out.push_back({make_float3(float(m[0] / len), float(m[1] / len), float(m[2] / len)),
                           make_float3(float(L[0]), float(L[1]), float(L[2])), float(omega)});
        }
    return out;
}

// The direction of row r, column c of the tail table (SkyLight::Tail).
float3 tailDirection(float r, float c, int W, int H)
{
    const float theta = float(M_PI) * (r + 0.5f) / float(H), phi = 2.0f * float(M_PI) * (c + 0.5f) / float(W);
    return make_float3(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
}

// The sky grid's shadow rays march the full-resolution density over this many node spacings
// from their start before the coarse estimate takes over (build(), shadowRay), and stop where
// that stretch's optical depth exceeds kNearOpaque in every channel (T < 1e-5).
constexpr float kNearSpacings = 4.0f;
constexpr float kNearOpaque = 11.5f;
constexpr int kNearStepsMax = 128;
// A node's neighbourhood whose coarse density varies by less than this many optical depths per
// node spacing is smooth (CoarseDensity::smooth): the sweep's optical depth is read there.
constexpr float kSmoothTau = 0.1f;

// The centre of octant s of a cell of side 1 centred at the origin.
float3 octant(int s)
{
    return make_float3(s & 1 ? 0.25f : -0.25f, s & 2 ? 0.25f : -0.25f, s & 4 ? 0.25f : -0.25f);
}

// A volume's density averaged over each sky-grid node's cell (eight octant samples), for the
// grid's shadow rays: light reaching a node's cell is resolved at the node spacing anyway, and
// marching this small dense array costs a fraction of the full-resolution brick walk.
struct CoarseDensity {
    const VolumeData* vol = nullptr;
    float3 origin = splat(0.0f);
    float spacing = 1.0f, invSpacing = 1.0f;
    int nx = 0, ny = 0, nz = 0;
    std::vector<float> rho;
    Rgb sigmaT = splat(0.0f);
    float spacingMetres = 1.0f;  // the node spacing in metres, by the volume's largest voxel side
    // Per node: whether the coarse density around it (the node and its 26 neighbours) varies by
    // less than kSmoothTau optical depths per node spacing, where the sweep's optical depth,
    // interpolated between nodes, is as good as a full-resolution ray (markSmooth).
    std::vector<uint8_t> smooth;

    float sigmaTMin() const { return std::max(1e-30f, std::min(sigmaT.x, std::min(sigmaT.y, sigmaT.z))); }
    // The full-resolution shadow rays' step (metres) along a direction of wi index units per
    // metre: half a voxel, or a quarter of the densest voxel's mean free path where longer (a
    // large, thin volume).
    float nearStep(float3 wi) const
    {
        const float sigmaMax = std::max(sigmaT.x, std::max(sigmaT.y, sigmaT.z)) * vol->density.maxValue();
        return std::max(0.5f / length(wi), sigmaMax > 0.0f ? 0.25f / sigmaMax : 1e30f);
    }
    // Whether the node nearest index point q is smooth (outside the grid: no density, smooth).
    bool smoothAt(float3 q) const
    {
        const float3 f = (q - origin) * invSpacing;
        const int i = int(std::floor(f.x + 0.5f)), j = int(std::floor(f.y + 0.5f)), k = int(std::floor(f.z + 0.5f));
        if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz)
            return true;
        return smooth[(size_t(k) * ny + j) * nx + i] != 0;
    }
    void markSmooth()
    {
        const float limit = kSmoothTau / std::max(1e-30f, std::max(sigmaT.x, std::max(sigmaT.y, sigmaT.z)) * spacingMetres);
        smooth.assign(rho.size(), 0);
        for (int k = 0; k < nz; ++k)
            for (int j = 0; j < ny; ++j)
                for (int i = 0; i < nx; ++i) {
                    float lo = 1e30f, hi = 0.0f;
                    for (int dk = -1; dk <= 1; ++dk)
                        for (int dj = -1; dj <= 1; ++dj)
                            for (int di = -1; di <= 1; ++di) {
                                const int a = i + di, b = j + dj, c = k + dk;
                                const float r = a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz ? 0.0f : at(a, b, c);
                                lo = std::min(lo, r), hi = std::max(hi, r);
                            }
                    smooth[(size_t(k) * ny + j) * nx + i] = hi - lo < limit;
                }
    }

    float at(int i, int j, int k) const { return rho[(size_t(k) * ny + j) * nx + i]; }
    // Trilinear in node units f (inside [0, n-1]^3).
    float sample(float3 f) const
    {
        const int i = std::min(int(f.x), nx - 2), j = std::min(int(f.y), ny - 2), k = std::min(int(f.z), nz - 2);
        const float tx = f.x - i, ty = f.y - j, tz = f.z - k;
        auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
        const float c00 = lerp(at(i, j, k), at(i + 1, j, k), tx), c10 = lerp(at(i, j + 1, k), at(i + 1, j + 1, k), tx);
        const float c01 = lerp(at(i, j, k + 1), at(i + 1, j, k + 1), tx),
                    c11 = lerp(at(i, j + 1, k + 1), at(i + 1, j + 1, k + 1), tx);
        return lerp(lerp(c00, c10, ty), lerp(c01, c11, ty), tz);
    }
    // Optical depth (RGB) from world point p along unit world direction w out of the grid, by
    // the midpoint rule at `step` nodes. A raised `stop` ends it early (the build then throws).
    Rgb opticalDepth(float3 p, float3 w, float step, const StopFlag* stop, float tMax = 1e30f) const
    {
        if (nx < 2 || ny < 2 || nz < 2)
            return splat(0.0f);
        const float3 f0 = (vol->indexFromWorld.point(p) - origin) * invSpacing;
        const float3 df = vol->indexFromWorld.vector(w) * invSpacing;  // nodes per metre
        float t0 = 0.0f, t1 = tMax;
        const float lo[3] = {0, 0, 0}, hi[3] = {float(nx - 1), float(ny - 1), float(nz - 1)};
        const float o[3] = {f0.x, f0.y, f0.z}, d[3] = {df.x, df.y, df.z};
        for (int a = 0; a < 3; ++a) {
            if (d[a] == 0.0f) {
                if (o[a] < lo[a] || o[a] > hi[a])
                    return splat(0.0f);
                continue;
            }
            float ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
            if (ta > tb)
                std::swap(ta, tb);
            t0 = std::max(t0, ta), t1 = std::min(t1, tb);
        }
        if (!(t1 > t0))
            return splat(0.0f);
        const float dt = step / length(df);  // metres per step
        const int n = stepCount(t1 - t0, dt);
        const float h = (t1 - t0) / float(n);
        double tau = 0.0;
        for (int s = 0; s < n; ++s) {
            float3 f = f0 + df * (t0 + (float(s) + 0.5f) * h);
            f = make_float3(clamp(f.x, 0.0f, hi[0]), clamp(f.y, 0.0f, hi[1]), clamp(f.z, 0.0f, hi[2]));
            tau += sample(f);
            if (unsigned(s) % kStopPollInterval == kStopPollInterval - 1 && stopRaised(stop))
                break;
        }
        return sigmaT * float(tau * h);
    }
};

}  // namespace

SkyLight SkyLight::build(const VolumeSet& volumes, const EmbreeScene* casters, const EnvironmentMap* map, Rgb colour,
                         const Settings& settings, const StopFlag* stop)
{
    const auto t0 = std::chrono::steady_clock::now();
    SkyLight sky;
    sky.mOrder = std::max(0, std::min(settings.order, kOrderMax));
    const int count = sky.count();
    // A uniform sky is a constant map: the same cells, so that it and a constant map agree.
    std::unique_ptr<EnvironmentMap> uniform;
    if (!map) {
        uniform = std::make_unique<EnvironmentMap>(2 * kCellColumns, 2 * kCellRows,
                                                   std::vector<float>(size_t(4 * kCellColumns * kCellRows) * 3, 1.0f),
                                                   0.0f);
        map = uniform.get();
    }
    const std::vector<Cell> cells = makeCells(*map, colour, sky.mOrder);

    // The phase tails (tailAlong), per volume: k(mu) = p(mu) - sum_(j<=J) (2j+1)/(4 pi) (p_j - f) P_j(mu)
    // summed over the sky's sources at each table direction (a uniform sky is its constant map).
    sky.mTails.resize(volumes.volumes().size());
    {
        const std::vector<SkySource> sources = skySources(*map, colour);
        Rgb mean = splat(0.0f);  // the sky's mean radiance, int L dOmega / 4 pi
        for (const SkySource& src : sources)
            mean += src.LdOmega * float(1.0 / (4.0 * M_PI));
        for (size_t v = 0; v < volumes.volumes().size(); ++v) {
            const NbPhase phase = volumes.volumes()[v]->medium.phase;
            if (std::pow(double(nbPhaseMomentBound(phase)), sky.mOrder + 1) < kTailNegligible)
                continue;
            nb_moment pj[kOrderMax + 1] = {};
            nbPhaseAddMoments(phase, 1.0, sky.mOrder, pj);
            const double f = forwardPeak(phase, sky.mOrder);
            // k tabulated in s = sqrt(1 - mu), even in the scattering angle near the forward
            // direction where a lobe of large g is narrow (s ~ theta / sqrt 2), read linearly.
            constexpr int kTable = 2048;
            std::vector<float> table(kTable + 1);
            for (int n = 0; n <= kTable; ++n) {
                const double sq = std::sqrt(2.0) * n / kTable, mu = 1.0 - sq * sq;
                double k = nbPhaseEval(phase, float(mu)), P0 = 1.0, P1 = mu;
                for (int j = 0; j <= sky.mOrder; ++j) {
                    k -= (2 * j + 1) / (4 * M_PI) * (double(pj[j]) - f) * (j == 0 ? P0 : P1);
                    if (j >= 1) {  // P_(j+1) from P_j and P_(j-1)
                        const double next = ((2 * j + 1) * mu * P1 - j * P0) / (j + 1);
                        P0 = P1, P1 = next;
                    }
                }
                table[size_t(n)] = float(k);
            }
            const float toIndex = float(kTable) / std::sqrt(2.0f);
            Tail& tail = sky.mTails[v];
            tail.rgb.assign(size_t(Tail::W * Tail::H) * 3, 0.0f);
            tbb::parallel_for(0, Tail::H, [&](int r) {
                for (int c = 0; c < Tail::W; ++c) {
                    const float3 d = tailDirection(float(r), float(c), Tail::W, Tail::H);
                    float acc[3] = {0, 0, 0}, kOmega = 0;
                    for (const SkySource& src : sources) {
                        const float x = std::sqrt(std::max(0.0f, 1.0f - dot(src.w, d))) * toIndex;
                        const int n = std::min(int(x), kTable - 1);
                        const float k = table[size_t(n)] + (x - float(n)) * (table[size_t(n) + 1] - table[size_t(n)]);
                        acc[0] += k * src.LdOmega.x, acc[1] += k * src.LdOmega.y, acc[2] += k * src.LdOmega.z;
                        kOmega += k * src.dOmega;
                    }
                    // int k dOmega = f (k's moment 0): the quadrature's excess over it removed
                    // with the sky's mean, so that a constant sky's tail is exactly f L.
                    float* out = tail.rgb.data() + 3 * (size_t(r) * Tail::W + c);
                    const float excess = kOmega - float(f);
                    out[0] = acc[0] - excess * mean.x, out[1] = acc[1] - excess * mean.y, out[2] = acc[2] - excess * mean.z;
                }
            });
        }
    }

    // Phase 1: each volume's grid and its coarse density.
    const auto& vols = volumes.volumes();
    std::vector<CoarseDensity> coarse(vols.size());
    for (size_t v = 0; v < vols.size(); ++v) {
        const VolumeData& vol = *vols[v];
        Grid g;
        const Bbox b = vol.density.activeIndexBounds();
        if (!b.empty()) {
            const float3 ext = b.hi - b.lo;
            const float largest = std::max(ext.x, std::max(ext.y, ext.z));
            g.spacing = std::max(1.0f, largest / float(std::max(1, settings.nodesAcross - 1)));
            g.invSpacing = 1.0f / g.spacing;
            g.origin = b.lo;
            g.nx = int(std::ceil(ext.x * g.invSpacing)) + 1;
            g.ny = int(std::ceil(ext.y * g.invSpacing)) + 1;
            g.nz = int(std::ceil(ext.z * g.invSpacing)) + 1;
            g.stride = 4 * ((count + 1) & ~1);
            g.L.assign(size_t(g.nx) * size_t(g.ny) * size_t(g.nz) * size_t(g.stride), 0.0f);
        }
        CoarseDensity& c = coarse[v];
        c.vol = &vol;
        c.origin = g.origin, c.spacing = g.spacing, c.invSpacing = g.invSpacing;
        c.nx = g.nx, c.ny = g.ny, c.nz = g.nz;
        c.sigmaT = vol.sigmaT();
        c.rho.assign(size_t(g.nx) * size_t(g.ny) * size_t(g.nz), 0.0f);
        tbb::parallel_for(tbb::blocked_range<int>(0, g.nz), [&](const tbb::blocked_range<int>& r) {
            for (int k = r.begin(); k != r.end(); ++k)
                for (int j = 0; j < g.ny; ++j) {
                    throwIfStopped(stop);
                    for (int i = 0; i < g.nx; ++i) {
                        const float3 q = g.origin + make_float3(float(i), float(j), float(k)) * g.spacing;
                        float sum = 0.0f;
                        for (int s = 0; s < 8; ++s)
                            sum += std::max(0.0f, vol.density.sample(q + octant(s) * g.spacing));
                        c.rho[(size_t(k) * g.ny + j) * g.nx + i] = sum / 8.0f;
                    }
                }
        });
        const float3 vx = vol.worldFromIndex.vector(make_float3(1, 0, 0)), vy = vol.worldFromIndex.vector(make_float3(0, 1, 0)),
                     vz = vol.worldFromIndex.vector(make_float3(0, 0, 1));
        c.spacingMetres = g.spacing * std::max(length(vx), std::max(length(vy), length(vz)));
        c.markSmooth();
        sky.mGrids.push_back(std::move(g));
    }
    // One volume and no shadow casters (the common case): the optical depth toward each sky
    // cell at every node by one sweep per cell, as a deep shadow map is built, instead of a ray
    // per node. Layer by layer along the direction's dominant axis a, from the layer nearest
    // the light: tau(x) = tau(y) + (rho(x) + rho(y)) / 2 * |x - y|, y = x + v the point one layer
    // toward the light (v_a = +-1), tau and rho at y bilinear in that layer (0 outside the grid,
    // where no density is). tau in density x metres; sigma_t applied at the lookup.
    const bool sweep = vols.size() == 1 && !casters && sky.mGrids[0].nx > 0;
    std::vector<std::vector<float>> tauFields;
    if (sweep) {
        const CoarseDensity& c = coarse[0];
        tauFields.resize(cells.size());
        tbb::parallel_for(size_t(0), cells.size(), [&](size_t ci) {
            const float3 u = c.vol->indexFromWorld.vector(cells[ci].towardLight) * c.invSpacing;  // nodes per metre
            const float ul = length(u);
            const float un[3] = {u.x / ul, u.y / ul, u.z / ul};
            int a = 0;
            for (int q = 1; q < 3; ++q)
                if (std::fabs(un[q]) > std::fabs(un[a]))
                    a = q;
            const int b = (a + 1) % 3, d = (a + 2) % 3;
            const float va = un[a] > 0 ? 1.0f : -1.0f, vb = un[b] / std::fabs(un[a]), vd = un[d] / std::fabs(un[a]);
            const float stepMetres = 1.0f / (std::fabs(un[a]) * ul);
            // One layer's step toward the light in index units, and the samples along it, as far
            // apart as the shadow rays' full-resolution steps (nearStep).
            float vv[3];
            vv[a] = va, vv[b] = vb, vv[d] = vd;
            const float3 segment = make_float3(vv[0], vv[1], vv[2]) * c.spacing;
            const float sampleMetres = c.nearStep(segment * (1.0f / stepMetres));
            const int segmentSamples = std::min(stepCount(stepMetres, sampleMetres), kNearStepsMax / 8);
            const int n[3] = {c.nx, c.ny, c.nz};
            std::vector<float>& tau = tauFields[ci];
            tau.assign(c.rho.size(), 0.0f);
            // The point one layer toward the light is (ib + vb, id + vd): the same bilinear taps
            // and weights at every node of the sweep, (ob, od) + {0, 1}^2 from the node.
            const float fbv = std::floor(vb), fdv = std::floor(vd);
            const int ob = int(fbv), od = int(fdv);
            const float tb = vb - fbv, td = vd - fdv;
            const float wq[4] = {(1.0f - tb) * (1.0f - td), tb * (1.0f - td), (1.0f - tb) * td, tb * td};
            size_t strides[3] = {1, size_t(c.nx), size_t(c.nx) * size_t(c.ny)};
            const size_t sa = strides[a], sb = strides[b], sd = strides[d];
            // Nodes whose four taps all lie inside the layer: ib in [ibLo, ibHi].
            const int ibLo = std::max(0, -ob), ibHi = std::min(n[b] - 1, n[b] - 2 - ob);
            for (int step = 0; step < n[a]; ++step) {
                const int ia = va > 0 ? n[a] - 1 - step : step, up = ia + int(va);
                const bool inside = up >= 0 && up < n[a];
                for (int id = 0; id < n[d]; ++id) {
                    throwIfStopped(stop);
                    const int jd = id + od;
                    const bool rowsInside = jd >= 0 && jd + 1 < n[d];
                    const size_t row = size_t(ia) * sa + size_t(id) * sd;
                    for (int ib = 0; ib < n[b]; ++ib) {
                        const size_t x = row + size_t(ib) * sb;
                        float tauY = 0.0f, rhoY = 0.0f;
                        if (inside) {
                            if (rowsInside && ib >= ibLo && ib <= ibHi) {
                                const size_t y0 = size_t(up) * sa + size_t(jd) * sd + size_t(ib + ob) * sb;
                                const size_t y[4] = {y0, y0 + sb, y0 + sd, y0 + sb + sd};
                                for (int q = 0; q < 4; ++q) {
                                    tauY += tau[y[q]] * wq[q];
                                    rhoY += c.rho[y[q]] * wq[q];
                                }
                            } else {  // at the layer's edge: the taps outside are zero
                                for (int q = 0; q < 4; ++q) {
                                    const int kb = ib + ob + (q & 1), kd = jd + (q >> 1);
                                    if (kb < 0 || kb >= n[b] || kd < 0 || kd >= n[d])
                                        continue;
                                    const size_t yq = size_t(up) * sa + size_t(kd) * sd + size_t(kb) * sb;
                                    tauY += tau[yq] * wq[q];
                                    rhoY += c.rho[yq] * wq[q];
                                }
                            }
                        }
                        // The layer's stretch of the ray from the node toward the light, by the
                        // full-resolution density where the coarse one has any at either end.
                        float along = 0.0f;
                        if (c.rho[x] > 0.0f || rhoY > 0.0f) {
                            int idx[3];
                            idx[a] = ia, idx[b] = ib, idx[d] = id;
                            const float3 p0 = c.origin + make_float3(float(idx[0]), float(idx[1]), float(idx[2])) * c.spacing;
                            for (int s = 0; s < segmentSamples; ++s)
                                along += std::max(0.0f, c.vol->density.sample(p0 + segment * ((float(s) + 0.5f) / float(segmentSamples))));
                            along /= float(segmentSamples);
                        }
                        tau[x] = tauY + along * stepMetres;
                    }
                }
            }
        });
    }
    // The transmittance toward sky cell ci from index-space point q of volume 0, by the sweep.
    auto sweptTransmittance = [&](size_t ci, float3 q) {
        const CoarseDensity& c = coarse[0];
        const float3 f = (q - c.origin) * c.invSpacing;
        const float fx = clamp(f.x, 0.0f, float(c.nx - 1)), fy = clamp(f.y, 0.0f, float(c.ny - 1)),
                    fz = clamp(f.z, 0.0f, float(c.nz - 1));
        const int i = std::min(int(fx), std::max(c.nx - 2, 0)), j = std::min(int(fy), std::max(c.ny - 2, 0)),
                  k = std::min(int(fz), std::max(c.nz - 2, 0));
        const float tx = fx - i, ty = fy - j, tz = fz - k;
        const std::vector<float>& tau = tauFields[ci];
        float sum = 0.0f;
        for (int q8 = 0; q8 < 8; ++q8) {
            const int ci8 = std::min(i + (q8 & 1), c.nx - 1), cj8 = std::min(j + (q8 >> 1 & 1), c.ny - 1),
                      ck8 = std::min(k + (q8 >> 2 & 1), c.nz - 1);
            sum += tau[(size_t(ck8) * c.ny + cj8) * c.nx + ci8] * ((q8 & 1) ? tx : 1.0f - tx) *
                   ((q8 >> 1 & 1) ? ty : 1.0f - ty) * ((q8 >> 2 & 1) ? tz : 1.0f - tz);
        }
        if (c.sigmaT.x == c.sigmaT.y && c.sigmaT.y == c.sigmaT.z)  // a grey medium: one exponential
            return splat(std::exp(-c.sigmaT.x * sum));
        return exp(-(c.sigmaT * sum));
    };

    // A shadow ray from index point q of volume `vol` toward sky cell ci: the full-resolution
    // densities near its start, the coarse estimate (the sweep's, or a coarse ray) from there.
    // The coarse density spreads a surface over a node's cell, and the optical depth between
    // nodes, interpolated across a surface, has a kink there: read a fraction of a mean free path
    // under a surface, where the camera sees the sky's light, the coarse estimate alone
    // overestimated the optical depth (docs/single-scattering.md, "environment light": a
    // cumulus of 0.4 mean free paths per voxel under a uniform sky had its L1 14.8% low, a
    // sphere of one mean free path per voxel 33% low). With the sweep the ray marches until the
    // nearest node's neighbourhood is smooth (CoarseDensity::smooth), at most nearLength
    // (kNearSpacings node spacings); with a coarse ray, nearLength.
    // The sweep's full-resolution stretch along each sky cell's direction: volume 0's index units
    // per metre, the step count and length.
    struct NearRay {
        float3 wi;
        int n;
        float dt;
    };
    std::vector<NearRay> nearRays;
    auto shadowRay = [&](const VolumeData& vol, float3 q, size_t ci, float nearLength) -> Rgb {
        if (sweep) {
            const CoarseDensity& c = coarse[0];
            const VolumeData& vv = *c.vol;
            const float3 wi = nearRays[ci].wi;
            const int n = nearRays[ci].n;
            const float dt = nearRays[ci].dt;
            const float opaque = kNearOpaque / c.sigmaTMin() / dt;
            float rho = 0.0f, t = 0.0f;
            for (int k = 0; k < n && !c.smoothAt(q + wi * t); ++k, t += dt) {
                rho += std::max(0.0f, vv.density.sample(q + wi * (t + 0.5f * dt)));
                if ((k & 7) == 7 && rho > opaque)
                    return splat(0.0f);
            }
            const Rgb tau = c.sigmaT * (rho * dt);
            if (std::min(tau.x, std::min(tau.y, tau.z)) > kNearOpaque)
                return splat(0.0f);
            const float3 qe = q + wi * t;
            const float3 f = (qe - c.origin) * c.invSpacing;
            if (f.x >= 0.0f && f.y >= 0.0f && f.z >= 0.0f && f.x <= float(c.nx - 1) && f.y <= float(c.ny - 1) &&
                f.z <= float(c.nz - 1))
                return exp(-tau) * sweptTransmittance(ci, qe);
            return exp(-tau);  // past the grid's box along w: nothing more of the volume ahead
        }
        // Several volumes or shadow casters: nearLength by the full-resolution densities, then a
        // coarse ray from there.
        const float3 x = vol.worldFromIndex.point(q), w = cells[ci].towardLight;
        if (casters && casters->occluded(x, w, 0.0f, 1e30f))
            return splat(0.0f);
        Rgb tau = splat(0.0f);
        for (const CoarseDensity& c : coarse) {
            const VolumeData& vv = *c.vol;
            const float3 wi = vv.indexFromWorld.vector(w);
            const int n = std::min(stepCount(nearLength, c.nearStep(wi)), kNearStepsMax);
            const float dt = nearLength / float(n);
            const float3 qi = vv.indexFromWorld.point(x);
            float rho = 0.0f;
            for (int k = 0; k < n; ++k)
                rho += std::max(0.0f, vv.density.sample(qi + wi * ((float(k) + 0.5f) * dt)));
            tau += c.sigmaT * (rho * dt);
        }
        const float3 end = x + w * nearLength;
        for (const CoarseDensity& c : coarse)
            tau += c.opticalDepth(end, w, settings.shadowStep, stop);
        return exp(-tau);
    };

    // Phase 2: each node's coefficients.
    for (size_t v = 0; v < vols.size(); ++v) {
        const VolumeData& vol = *vols[v];
        Grid& g = sky.mGrids[v];
        if (g.nx == 0)
            continue;
        // Probes of the node's neighbourhood, the eight cells around it, at most 4 voxels apart:
        // a brick (8 voxels) that overlaps the neighbourhood holds one of them.
        const int probes = int(std::ceil(2.0f * g.spacing / 4.0f)) + 1;
        const int stride = g.stride;
        // The shadow rays' full-resolution stretch at most (metres).
        const float nearLength = kNearSpacings * coarse[v].spacingMetres;
        if (sweep) {
            nearRays.resize(cells.size());
            for (size_t ci = 0; ci < cells.size(); ++ci) {
                NearRay& r = nearRays[ci];
                r.wi = vol.indexFromWorld.vector(cells[ci].towardLight);
                r.n = std::min(stepCount(nearLength, coarse[0].nearStep(r.wi)), kNearStepsMax);
                r.dt = nearLength / float(r.n);
            }
        }
        tbb::parallel_for(tbb::blocked_range<int>(0, g.nz), [&](const tbb::blocked_range<int>& r) {
            std::vector<float> acc(static_cast<size_t>(stride));
            for (int k = r.begin(); k != r.end(); ++k)
                for (int j = 0; j < g.ny; ++j)
                    for (int i = 0; i < g.nx; ++i) {
                        throwIfStopped(stop);  // a node: 128 sky cells' shadow rays
                        const float3 q = g.origin + make_float3(float(i), float(j), float(k)) * g.spacing;
                        bool near = false;
                        for (int pz = 0; pz < probes && !near; ++pz)
                            for (int py = 0; py < probes && !near; ++py)
                                for (int px = 0; px < probes && !near; ++px) {
                                    const float3 o = make_float3(float(px), float(py), float(pz)) *
                                                         (2.0f * g.spacing / float(probes - 1)) -
                                                     splat(g.spacing);
                                    near = vol.density.stencil(q + o).brick >= 0;
                                }
                        if (!near)
                            continue;
                        // Weighted over the node's cell by what the camera sees there: eight
                        // sub-points at the octant centres, each taking the shadow rays of every
                        // eighth sky cell, weighted w_s / mean(w), w = rho T_cam (the density
                        // times the transmittance to the camera's eye, by the coarse densities;
                        // rho alone where there is no camera). The march reads the light where
                        // the medium is, not at the node: a node just outside a cloud's surface
                        // would otherwise carry T = 1 into the surface's samples (trilinear
                        // interpolation of a convex T overestimates it by ~ (sigma_t h)^2 / 8 per
                        // cell, and more at the surface). And under a surface the camera sees the
                        // first mean free path, where the sky's light is brightest: weighted by
                        // rho alone, a sphere of one mean free path per voxel came out 6.6% dark
                        // in L1 with exact shadow rays, +1.3% weighted by rho T_cam.
                        float3 sub[8];
                        float rho[8], rhoSum = 0.0f;
                        for (int s = 0; s < 8; ++s) {
                            sub[s] = q + octant(s) * g.spacing;
                            rho[s] = std::max(0.0f, vol.density.sample(sub[s]));
                            if (settings.hasViewer && rho[s] > 0.0f) {
                                const float3 x = vol.worldFromIndex.point(sub[s]);
                                const float3 toEye = settings.viewer - x;
                                const float dist = length(toEye);
                                Rgb tau = splat(0.0f);
                                if (dist > 0.0f)
                                    for (const CoarseDensity& c : coarse)
                                        tau += c.opticalDepth(x, toEye * (1.0f / dist), settings.shadowStep, stop, dist);
                                rho[s] *= std::exp(-nbAverage(tau));
                            }
                            rhoSum += rho[s];
                        }
                        std::fill(acc.begin(), acc.end(), 0.0);
                        for (size_t ci = 0; ci < cells.size(); ++ci) {
                            const Cell& c = cells[ci];
                            // The sub-point of cell ci (rotated per node so that neighbours differ);
                            // where the cell holds no density, the node itself.
                            const int s = int((ci + size_t(i + 3 * j + 5 * k)) % 8);
                            const float3 at = rhoSum > 0.0f ? sub[s] : q;
                            const float wgt = rhoSum > 0.0f ? 8.0f * rho[s] / rhoSum : 1.0f;
                            if (!(wgt > 0.0f))
                                continue;
                            const Rgb T = shadowRay(vol, at, ci, nearLength) * wgt;
                            const float T4[4] = {T.x, T.y, T.z, 0.0f};
                            const float* E = c.Epad.data();
                            for (int e = 0; e < stride; e += 4)
                                for (int ch = 0; ch < 4; ++ch)
                                    acc[size_t(e + ch)] += T4[ch] * E[e + ch];
                        }
                        float* out = g.L.data() + ((size_t(k) * g.ny + j) * g.nx + i) * size_t(stride);
                        std::copy(acc.begin(), acc.end(), out);
                    }
        });
    }
    sky.mSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return sky;
}

size_t SkyLight::memoryBytes() const
{
    size_t b = 0;
    for (const Grid& g : mGrids)
        b += g.L.size() * sizeof(float);
    for (const Tail& t : mTails)
        b += t.rgb.size() * sizeof(float);
    return b;
}

Rgb SkyLight::tailAlong(size_t volume, float3 d) const
{
    const Tail& t = mTails[volume];
    if (t.rgb.empty())
        return splat(0.0f);
    const float theta = std::acos(std::clamp(d.y, -1.0f, 1.0f));
    float phi = std::atan2(d.z, d.x);
    if (phi < 0.0f)
        phi += 2.0f * float(M_PI);
    const float r = std::clamp(theta * float(Tail::H) / float(M_PI) - 0.5f, 0.0f, float(Tail::H - 1));
    const float c = phi * float(Tail::W) / (2.0f * float(M_PI)) - 0.5f;
    const int r0 = std::min(int(r), Tail::H - 2), c0 = int(std::floor(c));
    const float fr = r - float(r0), fc = c - float(c0);
    auto at = [&](int rr, int cc) {
        cc = ((cc % Tail::W) + Tail::W) % Tail::W;
        const float* p = t.rgb.data() + 3 * (size_t(rr) * Tail::W + cc);
        return make_float3(p[0], p[1], p[2]);
    };
    return (at(r0, c0) * (1 - fc) + at(r0, c0 + 1) * fc) * (1 - fr) +
           (at(r0 + 1, c0) * (1 - fc) + at(r0 + 1, c0 + 1) * fc) * fr;
}

float SkyLight::forwardPeak(NbPhase phase, int order)
{
    if (std::pow(double(nbPhaseMomentBound(phase)), order + 1) < kTailNegligible)
        return 0.0f;  // build() makes no tail table either
    nb_moment pj[kOrderMax + 2] = {};
    nbPhaseAddMoments(phase, 1.0, order + 1, pj);
    return float(std::clamp<nb_moment>(pj[order + 1], 0, 1));
}

void SkyLight::contraction(NbPhase phase, float3 wo, float* a) const
{
    // The moments p_j less the forward peak, kept per thread for the last phase and order: every
    // camera (and wkb secondary) ray asks, mostly with one volume's phase.
    thread_local NbPhase lastPhase{};
    thread_local int lastOrder = -1;
    thread_local nb_moment pj[kOrderMax + 1];
    thread_local nb_moment f = 0;
    if (lastOrder != mOrder || std::memcmp(&lastPhase, &phase, sizeof phase) != 0) {
        std::fill(pj, pj + kOrderMax + 1, nb_moment(0));
        nbPhaseAddMoments(phase, 1.0, mOrder, pj);
        f = forwardPeak(phase, mOrder);
        lastPhase = phase, lastOrder = mOrder;
    }
    double y[kCountMax];
    shEvaluate(mOrder, wo, y);
    for (int j = 0; j <= mOrder; ++j)
        for (int m = -j; m <= j; ++m)
            a[shIndex(j, m)] = float((pj[j] - f) * y[shIndex(j, m)]);
}

void SkyLight::corners(size_t volume, int i, int j, int k, const float* a, Rgb* out, const int* previous) const
{
    const Grid& g = mGrids[volume];
    const int count = this->count(), pairs = g.stride / 8;
    // A neighbour across one face (axis `axis`, side `step`): corner c of the new cell with bit
    // `axis` at the near side is the old cell's corner across that bit.
    int keep = -1, keepBit = 0;
    if (previous) {
        const int d[3] = {i - previous[0], j - previous[1], k - previous[2]};
        const int moved = (d[0] != 0) + (d[1] != 0) + (d[2] != 0);
        for (int axis = 0; axis < 3 && moved == 1; ++axis)
            if (d[axis] == 1 || d[axis] == -1) {
                keepBit = 1 << axis;
                keep = d[axis] == 1 ? 0 : keepBit;  // the bit value of the corners kept
            }
    }
    if (keep >= 0)
        for (int c = 0; c < 8; ++c)
            if ((c & keepBit) == keep)
                out[c] = out[c ^ keepBit];
#if defined(__AVX2__) && defined(__FMA__)
    // a_jm four times over, two coefficients to a vector, as the nodes lay them out.
    __m256 A[(kCountMax + 1) / 2];
    for (int p = 0; p < pairs; ++p) {
        const float a0 = a[2 * p], a1 = 2 * p + 1 < count ? a[2 * p + 1] : 0.0f;
        A[p] = _mm256_setr_ps(a0, a0, a0, a0, a1, a1, a1, a1);
    }
#endif
    for (int c = 0; c < 8; ++c) {
        if (keep >= 0 && (c & keepBit) == keep)
            continue;
        const int ci = std::min(i + (c & 1), g.nx - 1), cj = std::min(j + (c >> 1 & 1), g.ny - 1),
                  ck = std::min(k + (c >> 2 & 1), g.nz - 1);
        const float* L = g.L.data() + ((size_t(ck) * g.ny + cj) * g.nx + ci) * size_t(g.stride);
#if defined(__AVX2__) && defined(__FMA__)
        // Two chains of sums, so that the multiply-adds overlap.
        __m256 s = _mm256_mul_ps(_mm256_loadu_ps(L), A[0]), s1 = _mm256_setzero_ps();
        int p = 1;
        for (; p + 1 < pairs; p += 2) {
            s1 = _mm256_fmadd_ps(_mm256_loadu_ps(L + 8 * p), A[p], s1);
            s = _mm256_fmadd_ps(_mm256_loadu_ps(L + 8 * p + 8), A[p + 1], s);
        }
        if (p < pairs)
            s1 = _mm256_fmadd_ps(_mm256_loadu_ps(L + 8 * p), A[p], s1);
        s = _mm256_add_ps(s, s1);
        alignas(16) float r[4];
        _mm_store_ps(r, _mm_add_ps(_mm256_castps256_ps128(s), _mm256_extractf128_ps(s, 1)));
        out[c] = make_float3(r[0], r[1], r[2]);
#else
        (void)pairs;
        Rgb s = splat(0.0f);
        for (int jm = 0; jm < count; ++jm)
            s += make_float3(L[4 * jm], L[4 * jm + 1], L[4 * jm + 2]) * a[jm];
        out[c] = s;
#endif
    }
}

std::vector<Rgb> SkyLight::nodeCoefficients(size_t volume, float3 q) const
{
    const Grid& g = mGrids[volume];
    const float3 f = (q - g.origin) * g.invSpacing;
    const int i = std::clamp(int(std::lround(f.x)), 0, g.nx - 1), j = std::clamp(int(std::lround(f.y)), 0, g.ny - 1),
              k = std::clamp(int(std::lround(f.z)), 0, g.nz - 1);
    const float* L = g.L.data() + ((size_t(k) * g.ny + j) * g.nx + i) * size_t(g.stride);
    std::vector<Rgb> out;
    for (int jm = 0; jm < count(); ++jm)
        out.push_back(make_float3(L[4 * jm], L[4 * jm + 1], L[4 * jm + 2]));
    return out;
}

}  // namespace nimbus
