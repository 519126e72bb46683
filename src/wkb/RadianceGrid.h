// RadianceGrid.h: a traced radiance cache for WKB's orders 3 and up (render.wkb_orders3 = "traced";
// docs/wkb.md "Orders 3 and up, traced").
//
// A regular world-space grid over the volumes' box. Each cell holds, per RGB channel, the radiance
// that has scattered at least twice, scattered once more toward the viewer (the camera's eye at the
// shutter's centre, e) and averaged over the cell's volume:
//
//     S(cell) = (1 / V_cell) int_cell dx int dw p(x; w . wo(x)) L(x, w),    wo(x) = (e - x) / |e - x|
//
// (w: the light's travel direction; p the phase function at x, normalised to 1 over the sphere,
// the sigma_s-weighted mixture where volumes overlap.) Units: L is W / (m^2 sr) and p 1/sr, so S
// is W / (m^2 sr): the in-scattered radiance per unit sigma_s. A camera sees each point along one
// direction only, so the cache holds that direction's in-scattering exactly instead of L's angular
// moments: no truncation of the phase function (spherical harmonics to order 5 left a sunlit
// cumulus at HG g 0.9 +6% bright in orders 3+, order 9 +0.4%: docs/validation.md "The cache
// projected toward the camera"), 3 floats per cell and layer instead of 108.
//
// The estimator (filled by vrl::traceOrders3, a layer above): light paths as the VRL light pass traces
// them (VrlLightPass.h). A segment leaving a path's k-th scattering vertex with flux Phi (W) along w,
// k >= 2, contributes to int_cell dx int dw p L the expected track length it spends in the cell,
// int_{cell} T(origin, t) p(w . wo(x(t))) dt (m / sr), times Phi: the track-length estimator of
// fluence (Phi * length / V is W / m^2) with the free flight's length replaced by its expectation
// given the segment (the transmittance, integrated exactly over piecewise-constant extinction), each
// step weighted by its phase value toward the viewer. Dividing by V_cell gives S.
//
// In-scattering from it at a camera point x (sigma_s(x) > 0) toward the camera:
//
//     L_s(x, wo) = sigma_s(x) S(x)                      (S trilinear between cell centres)
//
// The viewer is a point, so within a cell wo varies by the cell's angular size seen from it
// (under a degree for a cloud a few metres away at the default 48 cells); where the camera is
// inside the cache's box the cells next to it see wo turn across them, and the read there averages
// the directions.
//
// Layers. A cell holds `layers` such sets, side by side ([layer][rgb]): each light's own paths
// where per-light AOVs are written (a light's layer holds its paths' deposits only; the light pass
// already picks lights by power and divides by that probability, so each layer is an unbiased
// estimate of its light's part and the layers sum to the one-layer cache), else one layer summing
// every light. layerLight(k): the RenderContext::lights index whose AOV layer k feeds, or -1 (the
// lights whose AOVs are not written, summed; or all lights).
#pragma once

#include "../render/VolumeSet.h"
#include "../single/InScatterGrid.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace nimbus {
class ScatterPointSampler;
}

namespace nimbus::wkb {

class RadianceGrid {
public:
    static constexpr int kFloats = 3;  // per cell and layer: rgb

    // A grid over `box` with cubic cells no smaller than `minCell` (metres) and at most `maxCells`
    // cells along the box's longest side, with `layers` layers (at least 1).
    void init(const Bbox& box, float minCell, int maxCells, int layers = 1);
    // The cells init(box, minCell, maxCells) makes, without making them (0 for an empty box).
    static size_t cellCountFor(const Bbox& box, float minCell, int maxCells);

    int layers() const { return mLayers; }
    int floatsPerCell() const { return mLayers * kFloats; }  // [layer][rgb]
    // The light index (RenderContext::lights) of each layer, -1 for a layer of several lights.
    void setLayerLights(std::vector<int> lights) { mLayerLight = std::move(lights); }
    int layerLight(int layer) const
    {
        return size_t(layer) < mLayerLight.size() ? mLayerLight[size_t(layer)] : -1;
    }

    bool empty() const { return mData.empty(); }
    int size(int axis) const { return mN[axis]; }
    float cellSize() const { return mCell; }
    float cellVolume() const { return mCell * mCell * mCell; }
    size_t cellCount() const { return size_t(mN[0]) * size_t(mN[1]) * size_t(mN[2]); }
    const Bbox& box() const { return mBox; }
    std::vector<float>& data() { return mData; }
    const std::vector<float>& data() const { return mData; }

    // The cells crossed by o + t d (d unit), t in [t0, t1], in order: f(cell, ta, tb) for each
    // cell's stretch [ta, tb] (a 3D DDA, Amanatides and Woo 1987). f returns false to stop.
    template <class F>
    void walk(float3 o, float3 d, float t0, float t1, F&& f) const;

    // S per channel and layer at world point x (W / (m^2 sr)), trilinear between cell centres
    // (clamped at the box's edge cells), into out[floatsPerCell()] ([layer][rgb]); false (and
    // nothing written) outside the box. Multiply by sigma_s for L_s.
    bool fetch(float3 x, float* out) const;
    // The grid as the camera march reads it with L1's samples (InScatterGrid.h: the same trilinear
    // read, clamped at the edge cells); false (view untouched) for more than kMaxInScatterLayers
    // layers.
    bool view(InScatterGrid& view) const;

private:
    // The cell size and counts of init's grid; false for an empty box.
    static bool cells(const Bbox& box, float minCell, int maxCells, float& cell, int n[3]);
    Bbox mBox;
    int mN[3] = {0, 0, 0};
    int mLayers = 1;
    float mCell = 1.0f;
    std::vector<float> mData;
    std::vector<int> mLayerLight;
};

// Orders 3 and up along the camera ray o + t d (d unit), t in [0, tFar), from `grid`:
//
//     L = int dt T(0, t) sigma_s(t) S(x(t))
//
// marched over the volumes' spans in steps of stepScale times each span's step (jittered by
// `jitter` in [0, 1)), S constant over a step and T's decay integrated exactly within it, per
// channel. The ray must start at the viewer the grid was projected toward (a camera ray). The grid
// is read where the frame's light is (VolumeSet::sampleAt's lightPoint). Stops where T < 1e-4 in
// every channel. Returns the layers' sum; perLayer (grid.layers() entries, or null) gets each
// layer's own.
// The step of the renders' read of the cache (marchOrders3's stepScale), in L1 steps: the camera
// march's (WkbIntegrator) and the pilot rays' that measure the cache's noise (vrl::traceOrders3).
constexpr float kOrders3StepScale = 2.0f;

float3 marchOrders3(const VolumeSet& volumes, const RadianceGrid& grid, float3 o, float3 d, float tFar, float seconds,
                    float jitter, float stepFraction, float stepScale, float3* perLayer = nullptr);

// The same integral over the steps of a camera ray that a ScatterPointSampler has marched already
// (traced order 2's, TracedOrder2::add): its steps are marchOrders3's (twice the L1 step, at least
// half a voxel; split where thick, to T < 1e-4), so the medium is not read a second time. S is
// read at each step's probe point. Still volumes only: a moving volume's light point is where the
// frame's light is (VolumeSet::sampleAt), which the sampler does not keep.
float3 readOrders3(const RadianceGrid& grid, const ScatterPointSampler& steps, float3 o, float3 d,
                   float3* perLayer = nullptr);

template <class F>
void RadianceGrid::walk(float3 o, float3 d, float t0, float t1, F&& f) const
{
    if (mData.empty())
        return;
    const float3 invD = make_float3(1.0f / d.x, 1.0f / d.y, 1.0f / d.z);
    float a, b;
    if (!mBox.intersect(o, invD, t0, t1, a, b) || !(b > a))
        return;
    const float od[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z}, lo[3] = {mBox.lo.x, mBox.lo.y, mBox.lo.z};
    int cell[3], step[3];
    float tNext[3], tDelta[3];
    const float inv = 1.0f / mCell;
    const float tm = 0.5f * (a + std::fmin(b, a + 0.5f * mCell));  // a point surely inside the first cell
    for (int k = 0; k < 3; ++k) {
        const float u = (od[k] + dd[k] * tm - lo[k]) * inv;
        cell[k] = std::min(mN[k] - 1, std::max(0, int(std::floor(u))));
        if (dd[k] > 0.0f) {
            step[k] = 1;
            tNext[k] = (lo[k] + float(cell[k] + 1) * mCell - od[k]) / dd[k];
            tDelta[k] = mCell / dd[k];
        } else if (dd[k] < 0.0f) {
            step[k] = -1;
            tNext[k] = (lo[k] + float(cell[k]) * mCell - od[k]) / dd[k];
            tDelta[k] = -mCell / dd[k];
        } else {
            step[k] = 0;
            tNext[k] = INFINITY;
            tDelta[k] = INFINITY;
        }
    }
    float t = a;
    while (t < b) {
        const int k = tNext[0] < tNext[1] ? (tNext[0] < tNext[2] ? 0 : 2) : (tNext[1] < tNext[2] ? 1 : 2);
        const float te = std::fmin(std::fmax(tNext[k], t), b);
        const size_t c = (size_t(cell[2]) * size_t(mN[1]) + size_t(cell[1])) * size_t(mN[0]) + size_t(cell[0]);
        if (te > t && !f(c, t, te))
            return;
        t = te;
        cell[k] += step[k];
        tNext[k] += tDelta[k];
        if (cell[k] < 0 || cell[k] >= mN[k])
            return;
    }
}

}  // namespace nimbus::wkb
