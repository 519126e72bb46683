#include "RadianceGrid.h"

#include "../core/StepCount.h"
#include "../single/ScatterPoints.h"

namespace nimbus::wkb {

void RadianceGrid::init(const Bbox& box, float minCell, int maxCells, int layers)
{
    mData.clear();
    mN[0] = mN[1] = mN[2] = 0;
    mLayers = std::max(1, layers);
    if (!cells(box, minCell, maxCells, mCell, mN))
        return;
    // Centre the whole cells on the box.
    const float3 full = make_float3(float(mN[0]), float(mN[1]), float(mN[2])) * mCell;
    mBox.lo = box.center() - full * 0.5f;
    mBox.hi = box.center() + full * 0.5f;
    mData.assign(cellCount() * size_t(floatsPerCell()), 0.0f);
}

bool RadianceGrid::cells(const Bbox& box, float minCell, int maxCells, float& cell, int n[3])
{
    if (box.empty())
        return false;
    const float3 e = box.extent();
    const float longest = std::fmax(e.x, std::fmax(e.y, e.z));
    if (!(longest > 0.0f))
        return false;
    cell = std::fmax(minCell, longest / float(std::max(1, maxCells)));
    n[0] = std::max(1, int(std::ceil(e.x / cell)));
    n[1] = std::max(1, int(std::ceil(e.y / cell)));
    n[2] = std::max(1, int(std::ceil(e.z / cell)));
    return true;
}

size_t RadianceGrid::cellCountFor(const Bbox& box, float minCell, int maxCells)
{
    float cell = 0.0f;
    int n[3] = {0, 0, 0};
    return cells(box, minCell, maxCells, cell, n) ? size_t(n[0]) * size_t(n[1]) * size_t(n[2]) : 0;
}

bool RadianceGrid::fetch(float3 x, float* out) const
{
    if (mData.empty() || !mBox.contains(x))
        return false;
    const int F = floatsPerCell();
    std::fill(out, out + F, 0.0f);
    const float3 u = (x - mBox.lo) * (1.0f / mCell) - splat(0.5f);  // cell-centred coordinates
    const float uu[3] = {u.x, u.y, u.z};
    int i0[3], i1[3];
    float f[3];
    for (int k = 0; k < 3; ++k) {
        const float c = std::fmin(std::fmax(uu[k], 0.0f), float(mN[k] - 1));
        i0[k] = std::min(int(c), mN[k] - 1);
        i1[k] = std::min(i0[k] + 1, mN[k] - 1);
        f[k] = c - float(i0[k]);
    }
    for (int corner = 0; corner < 8; ++corner) {
        const int ix = corner & 1 ? i1[0] : i0[0], iy = corner & 2 ? i1[1] : i0[1], iz = corner & 4 ? i1[2] : i0[2];
        const float w = (corner & 1 ? f[0] : 1.0f - f[0]) * (corner & 2 ? f[1] : 1.0f - f[1]) *
                        (corner & 4 ? f[2] : 1.0f - f[2]);
        if (!(w > 0.0f))
            continue;
        const float* c = mData.data() + ((size_t(iz) * size_t(mN[1]) + size_t(iy)) * size_t(mN[0]) + size_t(ix)) * size_t(F);
        for (int k = 0; k < F; ++k)
            out[k] += w * c[k];
    }
    return true;
}

bool RadianceGrid::view(InScatterGrid& view) const
{
    if (mData.empty() || mLayers > kMaxInScatterLayers)
        return false;
    view.rgb = mData.data();
    view.layers = mLayers;
    for (int k = 0; k < 3; ++k)
        view.n[k] = mN[k];
    view.lo = mBox.lo;
    view.cell = mCell;
    return true;
}

namespace {

// The layers' sums ([layer][rgb]) as colours: their total, and each layer's into perLayer (or null).
float3 layerSums(const std::vector<double>& sums, int layers, float3* perLayer)
{
    float3 total = make_float3(0, 0, 0);
    for (int layer = 0; layer < layers; ++layer) {
        const double* q = sums.data() + 3 * layer;
        const float3 v = make_float3(float(q[0]), float(q[1]), float(q[2]));
        if (perLayer)
            perLayer[layer] = v;
        total += v;
    }
    return total;
}

}  // namespace

float3 marchOrders3(const VolumeSet& volumes, const RadianceGrid& grid, float3 o, float3 d, float tFar, float seconds,
                    float jitter, float stepFraction, float stepScale, float3* perLayer)
{
    thread_local std::vector<Span> spans;
    thread_local std::vector<double> sums;  // [layer][rgb]
    thread_local std::vector<float> S;      // one step's S, [layer][rgb]
    const int layers = grid.layers();
    sums.assign(size_t(3 * layers), 0.0);
    S.resize(size_t(grid.floatsPerCell()));
    thread_local std::vector<float> weights;
    thread_local std::vector<BrickGrid::Stencil> stencils;
    volumes.spansAt(seconds, o, d, 0.0f, std::min(tFar, 1e30f), stepFraction, spans);
    const size_t nv = volumes.volumes().size();
    weights.assign(nv, 0.0f);
    stencils.resize(nv);
    double T[3] = {1, 1, 1};
    for (const Span& sp : spans) {
        const float len = sp.t1 - sp.t0;
        if (!(len > 0.0f))
            continue;
        // Never under half the smallest voxel: the cache's cells span many voxels, and a finer
        // render.step (down to denormals, where the count would reach stepCount's bound and the
        // read would take hours) buys L1's shadows, not a better read of them.
        const int n = stepCount(len, std::max(stepScale * sp.step, 0.5f * volumes.minVoxelSize()));
        const float dt = len / float(n);
        for (int k = 0; k < n; ++k) {
            const float3 x = o + d * (sp.t0 + (float(k) + jitter) * dt);
            float3 lp;
            const MediumSample m = volumes.sampleAt(seconds, x, weights.data(), stencils.data(), &lp);
            const double st[3] = {m.sigma_t.x, m.sigma_t.y, m.sigma_t.z};
            const double ss[3] = {m.sigma_s.x, m.sigma_s.y, m.sigma_s.z};
            double decay[3], integral[3];
            for (int c = 0; c < 3; ++c) {
                const double y = st[c] * double(dt);
                decay[c] = std::exp(-y);
                integral[c] = y > 1e-6 ? -std::expm1(-y) / st[c] : double(dt) * (1.0 - 0.5 * y);  // int_0^dt e^{-st u} du
            }
            if (ss[0] + ss[1] + ss[2] > 0.0 && grid.fetch(lp, S.data()))
                for (int layer = 0; layer < layers; ++layer)
                    for (int c = 0; c < 3; ++c)
                        sums[size_t(3 * layer + c)] += T[c] * ss[c] * double(S[size_t(3 * layer + c)]) * integral[c];
            for (int c = 0; c < 3; ++c)
                T[c] *= decay[c];
            if (std::max(T[0], std::max(T[1], T[2])) < 1e-4)
                break;
        }
        if (std::max(T[0], std::max(T[1], T[2])) < 1e-4)
            break;
    }
    return layerSums(sums, layers, perLayer);
}

float3 readOrders3(const RadianceGrid& grid, const ScatterPointSampler& steps, float3 o, float3 d, float3* perLayer)
{
    thread_local std::vector<double> sums;  // [layer][rgb]
    thread_local std::vector<float> S;      // one step's S, [layer][rgb]
    const int layers = grid.layers();
    sums.assign(size_t(3 * layers), 0.0);
    S.resize(size_t(grid.floatsPerCell()));
    steps.forEachStep(o, d, [&](float, float dt, float3 x, const float* T, const float* b, const float* c) {
        if (!grid.fetch(x, S.data()))
            return;
        for (int ch = 0; ch < 3; ++ch) {
            // int_0^dt T e^{-c u} b du, T's decay integrated exactly within the step (as marchOrders3)
            const double y = double(c[ch]) * double(dt);
            const double integral = y > 1e-6 ? -std::expm1(-y) / double(c[ch]) : double(dt) * (1.0 - 0.5 * y);
            const double w = double(T[ch]) * double(b[ch]) * integral;
            for (int layer = 0; layer < layers; ++layer)
                sums[size_t(3 * layer + ch)] += w * double(S[size_t(3 * layer + ch)]);
        }
    });
    return layerSums(sums, layers, perLayer);
}

}  // namespace nimbus::wkb
