// RadianceGrid.h: a traced radiance cache for WKB's orders 3 and up (render.wkb_orders3 = "traced";
// docs/wkb.md "Orders 3 and up, traced").
//
// A regular world-space grid over the volumes' box. Each cell holds, per RGB channel, the projection
// onto the real orthonormal spherical harmonics y_jm (SphericalHarmonics.h), j <= kOrder (5), of the radiance
// that has scattered at least twice, averaged over the cell's volume:
//
//     L_jm(cell) = (1 / V_cell) int_cell dx int dw L(x, w) y_jm(w)        (w: the light's travel direction)
//
// Units: L is W / (m^2 sr); dw in sr and y_jm dimensionless per sr^(1/2) * sr^(1/2) (orthonormal on the
// sphere), so L_jm is W / m^2 (an angular moment of radiance, L_00 = fluence / sqrt(4 pi)).
//
// The estimator (filled by vrl::traceOrders3, a layer above): light paths as the VRL light pass traces
// them (VrlLightPass.h). A segment leaving a path's k-th scattering vertex with flux Phi (W) along w,
// k >= 2, contributes to int_cell dx L(x, w') y(w') dw' the expected track length it spends in the
// cell, int_{cell} T(origin, t) dt (m), times Phi y_jm(w): the track-length estimator of fluence
// (Phi * length / V is W / m^2) with the free flight's length replaced by its expectation given the
// segment (the transmittance, integrated exactly over piecewise-constant extinction). Dividing by
// V_cell gives L_jm in W / m^2.
//
// In-scattering from it at a camera point x toward the camera (direction wo = -d, the direction the
// scattered light travels), with p the phase function normalised to 1 over the sphere and
// p(w . wo) its value for light travelling along w scattered into wo:
//
//     L_s(x, wo) = sigma_s(x) int dw p(w . wo) L(x, w)
//                = sigma_s(x) sum_jm p_j L_jm(x) y_jm(wo)        (Funk-Hecke; p_j = 2 pi int p P_j, g^j for HG)
//
// so forward scattering (p_1 > 0) favours radiance travelling toward the camera, y evaluated at wo
// (tests/compare/test_wkb_orders3.cpp fails with wo flipped to d).
//
// Layers. A cell holds `layers` such sets, side by side ([layer][jm][rgb]): each light's own paths
// where per-light AOVs are written (a light's layer holds its paths' deposits only; the light pass
// already picks lights by power and divides by that probability, so each layer is an unbiased
// estimate of its light's part and the layers sum to the one-layer cache), else one layer summing
// every light. layerLight(k): the RenderContext::lights index whose AOV layer k feeds, or -1 (the
// lights whose AOVs are not written, summed; or all lights).
#pragma once

#include "../../kernels/shared/phase.h"
#include "../render/VolumeSet.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace nimbus::wkb {

class RadianceGrid {
public:
    // SH order j <= 5: at HG g 0.9 (p_j = 0.9^j) order 3 left a sunlit cumulus's orders 3+ 13% low
    // seen from the side; order 5 takes the calibration suite's L2plus energy errors from -3.9% to
    // +1.0% (cumulus_lit) and -4.3% to -0.5% (haze_box_against) at 1.25x the light pass's time
    // (docs/validation.md "Cache paths from the image, SH order 5").
    static constexpr int kOrder = 5;
    static constexpr int kCoeffs = 36;          // (kOrder + 1)^2
    static constexpr int kFloats = 3 * kCoeffs;  // per cell and layer: [jm][rgb]

    // A grid over `box` with cubic cells no smaller than `minCell` (metres) and at most `maxCells`
    // cells along the box's longest side, with `layers` layers (at least 1).
    void init(const Bbox& box, float minCell, int maxCells, int layers = 1);
    // The cells init(box, minCell, maxCells) makes, without making them (0 for an empty box).
    static size_t cellCountFor(const Bbox& box, float minCell, int maxCells);

    int layers() const { return mLayers; }
    int floatsPerCell() const { return mLayers * kFloats; }  // [layer][jm][rgb]
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

    // The kCoeffs L_jm per channel and layer at world point x, trilinear between cell centres
    // (clamped at the box's edge cells), into out[floatsPerCell()] ([layer][jm][rgb]); false (and
    // nothing written) outside the box.
    bool fetch(float3 x, float* out) const;

    // sum_jm p_j L_jm(x) y_jm(wo) per channel (W / (m^2 sr)) of each layer into out[layers()]: the
    // phase-weighted radiance arriving at x, scattered into wo; y[jm] = y_jm(wo) (shEvaluate, kCoeffs
    // of them: one direction per camera ray), p the phase moments p_0..p_kOrder. Multiply by sigma_s
    // for L_s. False (out untouched) outside the box.
    bool inScatterY(float3 x, const double* y, const double* p, double (*out)[3]) const;

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
//     L = int dt T(0, t) sigma_s(t) sum_jm p_j(t) L_jm(x(t)) y_jm(wo)
//
// marched over the volumes' spans in steps of stepScale times each span's step (jittered by
// `jitter` in [0, 1)), the coefficients constant over a step and T's decay integrated exactly
// within it, per channel. p_j(t): the sigma_s-weighted mixture of the volumes' phase moments
// (two-lobe phases included, nbPhaseAddMoments). wo is the direction toward the camera, -d; tests
// pass others to show that only -d matches the path tracer. The grid is read where the frame's
// light is (VolumeSet::sampleAt's lightPoint). Stops where T < 1e-4 in every channel; each layer's
// sum is clamped at 0 per channel. Returns the layers' sum; perLayer (grid.layers() entries, or
// null) gets each layer's own.
// The step of the renders' read of the cache (marchOrders3's stepScale), in L1 steps: the camera
// march's (WkbIntegrator) and the pilot rays' that measure the cache's noise (vrl::traceOrders3).
constexpr float kOrders3StepScale = 2.0f;

float3 marchOrders3(const VolumeSet& volumes, const std::vector<NbPhase>& phases, const RadianceGrid& grid, float3 o,
                    float3 d, float3 wo, float tFar, float seconds, float jitter, float stepFraction,
                    float stepScale, float3* perLayer = nullptr);

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
