#include "SkyLight.h"

#include "../geometry/EmbreeScene.h"
#include "SphericalHarmonics.h"
#include "VolumeSet.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace nimbus {

namespace {

// One cell of the sphere: its texels' exact sum of y_jm(n') L dOmega (n' = -w, the direction
// the light travels; RGB innermost) and the direction its shadow rays take.
struct Cell {
    std::vector<double> E;
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

}  // namespace

SkyLight SkyLight::build(const VolumeSet& volumes, const EmbreeScene* casters, const EnvironmentMap* map, Rgb colour,
                         const Settings& settings)
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

    for (const auto& vp : volumes.volumes()) {
        const VolumeData& vol = *vp;
        Grid g;
        const Bbox b = vol.density.activeIndexBounds();
        if (b.empty()) {
            sky.mGrids.push_back(std::move(g));
            continue;
        }
        const float3 ext = b.hi - b.lo;
        const float largest = std::max(ext.x, std::max(ext.y, ext.z));
        g.spacing = std::max(1.0f, largest / float(std::max(1, settings.nodesAcross - 1)));
        g.invSpacing = 1.0f / g.spacing;
        g.origin = b.lo;
        g.nx = int(std::ceil(ext.x * g.invSpacing)) + 1;
        g.ny = int(std::ceil(ext.y * g.invSpacing)) + 1;
        g.nz = int(std::ceil(ext.z * g.invSpacing)) + 1;
        g.L.assign(size_t(g.nx) * size_t(g.ny) * size_t(g.nz) * size_t(3 * count), 0.0f);
        const float stepVoxels = settings.shadowStep * g.spacing;
        // Probes of the node's neighbourhood, the eight cells around it, at most 4 voxels apart:
        // a brick (8 voxels) that overlaps the neighbourhood holds one of them.
        const int probes = int(std::ceil(2.0f * g.spacing / 4.0f)) + 1;
        tbb::parallel_for(tbb::blocked_range<int>(0, g.nz), [&](const tbb::blocked_range<int>& r) {
            std::vector<double> acc(size_t(3 * count));
            for (int k = r.begin(); k != r.end(); ++k)
                for (int j = 0; j < g.ny; ++j)
                    for (int i = 0; i < g.nx; ++i) {
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
                        const float3 p = vol.worldFromIndex.point(q);
                        std::fill(acc.begin(), acc.end(), 0.0);
                        for (const Cell& c : cells) {
                            if (casters && casters->occluded(p, c.towardLight, 0.0f, 1e30f))
                                continue;
                            const Rgb T = exp(-volumes.opticalDepth(p, c.towardLight, 0.0f, 1e30f, stepVoxels));
                            for (int jm = 0; jm < count; ++jm) {
                                acc[3 * jm + 0] += T.x * c.E[3 * jm + 0];
                                acc[3 * jm + 1] += T.y * c.E[3 * jm + 1];
                                acc[3 * jm + 2] += T.z * c.E[3 * jm + 2];
                            }
                        }
                        float* out = g.L.data() + ((size_t(k) * g.ny + j) * g.nx + i) * size_t(3 * count);
                        for (int c = 0; c < 3 * count; ++c)
                            out[c] = float(acc[c]);
                    }
        });
        sky.mGrids.push_back(std::move(g));
    }
    sky.mSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return sky;
}

size_t SkyLight::memoryBytes() const
{
    size_t b = 0;
    for (const Grid& g : mGrids)
        b += g.L.size() * sizeof(float);
    return b;
}

void SkyLight::contraction(NbPhase phase, float3 wo, float* a) const
{
    nb_moment pj[kOrderMax + 1] = {};
    nbPhaseAddMoments(phase, 1.0, mOrder, pj);
    double y[kCountMax];
    shEvaluate(mOrder, wo, y);
    for (int j = 0; j <= mOrder; ++j)
        for (int m = -j; m <= j; ++m)
            a[shIndex(j, m)] = float(pj[j] * y[shIndex(j, m)]);
}

Rgb SkyLight::radiance(size_t volume, float3 q, const float* a, Cursor& cursor) const
{
    const Grid& g = mGrids[volume];
    if (g.nx == 0)
        return splat(0.0f);
    const float3 f = (q - g.origin) * g.invSpacing;
    auto split = [](float x, int n, int& i) {
        if (n < 2) {
            i = 0;
            return 0.0f;
        }
        x = clamp(x, 0.0f, float(n - 1));
        i = std::min(int(x), n - 2);
        return x - float(i);
    };
    int i, j, k;
    const float tx = split(f.x, g.nx, i), ty = split(f.y, g.ny, j), tz = split(f.z, g.nz, k);
    const long cell = (long(k) * g.ny + j) * g.nx + i;
    if (cell != cursor.cell) {
        const int count = this->count();
        for (int c = 0; c < 8; ++c) {
            const int ci = std::min(i + (c & 1), g.nx - 1), cj = std::min(j + (c >> 1 & 1), g.ny - 1),
                      ck = std::min(k + (c >> 2 & 1), g.nz - 1);
            const float* L = g.L.data() + ((size_t(ck) * g.ny + cj) * g.nx + ci) * size_t(3 * count);
            Rgb s = splat(0.0f);
            for (int jm = 0; jm < count; ++jm)
                s += make_float3(L[3 * jm], L[3 * jm + 1], L[3 * jm + 2]) * a[jm];
            cursor.corner[c] = s;
        }
        cursor.cell = cell;
    }
    const Rgb* c = cursor.corner;
    const Rgb x00 = c[0] + (c[1] - c[0]) * tx, x10 = c[2] + (c[3] - c[2]) * tx;
    const Rgb x01 = c[4] + (c[5] - c[4]) * tx, x11 = c[6] + (c[7] - c[6]) * tx;
    const Rgb y0 = x00 + (x10 - x00) * ty, y1 = x01 + (x11 - x01) * ty;
    return fmax(y0 + (y1 - y0) * tz, splat(0.0f));
}

std::vector<Rgb> SkyLight::nodeCoefficients(size_t volume, float3 q) const
{
    const Grid& g = mGrids[volume];
    const float3 f = (q - g.origin) * g.invSpacing;
    const int i = std::clamp(int(std::lround(f.x)), 0, g.nx - 1), j = std::clamp(int(std::lround(f.y)), 0, g.ny - 1),
              k = std::clamp(int(std::lround(f.z)), 0, g.nz - 1);
    const float* L = g.L.data() + ((size_t(k) * g.ny + j) * g.nx + i) * size_t(3 * count());
    std::vector<Rgb> out;
    for (int jm = 0; jm < count(); ++jm)
        out.push_back(make_float3(L[3 * jm], L[3 * jm + 1], L[3 * jm + 2]));
    return out;
}

}  // namespace nimbus
