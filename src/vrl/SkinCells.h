// SkinCells.h: the cells of WKB's traced orders-3+ cache (wkb/RadianceGrid.h) that hold the
// camera-weighted mean of the radiance instead of its volume mean (docs/wkb.md "Orders 3 and up,
// traced", "Skin cells").
//
// A cell averages the radiance over its volume. Where that radiance varies within the cell by
// more than the camera can see of it (a lit face of a thick medium, whose orders 3+ live within a
// few diffusion lengths of the face while a cell is many mean free paths deep), the volume mean is
// not what a camera ray through the cell gathers: the ray sees the first mean free path under
// the face, the mean dilutes it with the depths below (a lit half-space at albedo 0.8-0.95 came
// out 23-45% dark). There the cell holds the mean weighted by the camera's in-scattering
// importance,
//
//     S(cell) = int_cell sigma_s T_cam S dV / int_cell sigma_s T_cam dV,
//
// T_cam(x) the transmittance from x to the camera: the camera ray's own integrand, so that a ray
// through the cell gathers from it what it would gather from the radiance's profile under the
// face (exactly so where the radiance, the medium and T_cam vary along one direction). Units:
// the numerator W/sr (a segment's flux times its expected track length times sigma_s times the
// phase function toward the camera), the denominator m^2, the ratio W/(m^2 sr) as every cell's S
// (RadianceGrid.h).
//
// - The denominator is measured by camera rays (findSkinCells): a regular grid of rays over the
//   image, each of solid angle dOmega standing for the volume t^2 dOmega dt along it.
// - The numerator by the light paths (Orders3Grid.cpp): a segment crossing a skin cell deposits,
//   instead of its track length, Phi int sigma_s T T_cam p dt over its stretch there, estimated
//   without bias by one point drawn by sigma_s T along the stretch (SkinPoint), the phase function
//   toward the camera there, and T_cam marched from it to the camera (cameraTransmittance); points outside the camera's view count 0, as the
//   camera rays do not see them.
// - A cell is a skin cell where the camera sees its neighbourhood (kSkinRadius cells each side)
//   and the diffusion length there, 1 / (sigma_t sqrt(3 (1 - omega)(1 - g omega))), is at most the
//   cell's size over kSkinDiffusionLengths: there the radiance varies within a cell. sigma_t is the
//   largest the rays sampled in the neighbourhood (the medium under the face: a camera-weighted
//   mean reads the face's one-voxel density ramp, 0.3 of the slab's extinction at 19 mean free
//   paths per voxel, and missed a half-space at albedo 0.999); albedo and mean cosine are
//   camera-weighted means. Or where the cell is kSkinTransportLengths transport mean free paths
//   1 / (sigma_t (1 - g omega)) across or more: at high albedo the diffusion length is long (33 mean
//   free paths at albedo 0.999, g 0.7), but under a lit face the radiance still has a boundary layer
//   of a few transport lengths (the diffusion solution's linear rise from an extrapolated zero
//   0.71 transport lengths outside the face), which a camera sees into and a cell many of them deep
//   averages away: the half-space table's albedo-0.999 rows came out -10% to -22% with the volume
//   mean at 4 mean free paths per voxel, within 7.3% with it made a skin cell. The
//   neighbourhood, not the cell alone: rays sample a cell's cross-section at points, and a cell's
//   own integrals alias with their spacing, while the skin cells' set must cover the same region
//   in the numerators as the rays cover in the denominators (checked while it was written, with
//   every cell made a skin cell: orders 3+ of test_wkb_orders3's thin sphere and cloud came out
//   +1.7% and +0.6% against the path tracer, the volume means -0.1% and -3.1%; with each cell
//   classified alone, -35% and -29%).
// - The deposit's steps in a skin cell are at most half an optical depth (skinSubSteps): a
//   voxel-long step with the extinction of its middle spread a face's one-voxel density ramp as if
//   it were uniform, and T_cam at the drawn point (marched through the true ramp) then disagreed
//   with it: orders 3+ of a lit face came out +13%, +10% and +3.5% with 24, 48 and 96 cells, and
//   +1.7%, +1.5% and +1.2% with the sub-steps.
// - Numerators and denominators are each summed over the skin cells within kSkinRadius cells (tent
//   weights) before their ratio is taken: one point per stretch leaves the numerator noisy, and a
//   skin follows a face, along which its radiance is smooth.
#pragma once

#include "../render/RenderContext.h"
#include "../wkb/RadianceGrid.h"

#include <vector>

namespace nimbus::vrl {

// Fitted on the calibration suite (docs/validation.md, "Skin cells"): a cell this many diffusion
// lengths across or more is a skin cell.
constexpr float kSkinDiffusionLengths = 1.0f;
// A cell this many transport mean free paths across or more is a skin cell too (the boundary
// layer's argument above; the calibration suite's scenes come out the same with 2 and 4, 0.5 loses
// core_twolobe_lit; docs/validation.md "Skin cells at high albedo").
constexpr float kSkinTransportLengths = 2.0f;
// The skin cells' neighbourhood whose numerators and denominators are summed (cells each side).
constexpr int kSkinRadius = 2;

// Whether a cell this many transport mean free paths 1 / (sigma_t (1 - g omega)) and diffusion
// lengths 1 / (sigma_t sqrt(3 (1 - omega)(1 - g omega))) across is of a skin cell's size (the
// thresholds above); findSkinCells, and orders3GridCells, which refines the cells short of it.
inline bool skinCellScale(double transportLengths, double diffusionLengths)
{
    return transportLengths >= double(kSkinTransportLengths) || diffusionLengths >= double(kSkinDiffusionLengths);
}

struct SkinCells {
    std::vector<int> slot;      // per cell of the grid: its index among the skin cells, or -1
    std::vector<float> weight;  // per skin cell: int sigma_s T_cam dV per channel (m^2)
    float3 camera = make_float3(0, 0, 0);
    // The view: its axis, and right and up scaled so that dot(x - camera, right) / dot(x - camera,
    // forward) spans [-1, 1] across the image (up likewise).
    float3 forward = make_float3(0, 0, 1), right = make_float3(1, 0, 0), up = make_float3(0, 1, 0);

    size_t count() const { return weight.size() / 3; }
    int slotOf(size_t cell) const { return slot.empty() ? -1 : slot[cell]; }
    bool inView(float3 x) const
    {
        const float3 v = x - camera;
        const float z = dot(v, forward);
        return z > 0.0f && std::fabs(dot(v, right)) <= z && std::fabs(dot(v, up)) <= z;
    }
};

// The skin cells of `grid` as ctx's camera sees it (at the shutter's centre). None where the
// scene has no camera or no cell qualifies. Serial and deterministic: a few thousand rays.
SkinCells findSkinCells(const RenderContext& ctx, const wkb::RadianceGrid& grid);

// The memory findSkinCells holds while it runs for a grid of `cells` cells (bytes).
size_t skinCellsBytes(size_t cells);

// The transmittance from x to `camera` through ctx's volumes, per channel, marched in steps of
// at most a voxel and half an optical depth; 0 once below 1e-4 in every channel.
Rgb cameraTransmittance(const VolumeSet& volumes, float3 x, float3 camera);

// Steps for the segment o + t d, t in [0, len], each at most half an optical depth at the
// largest extinction of its ends and middle (a face inside it, whose density ramps over a voxel,
// is then resolved even where the middle is outside it); at most 4096.
int skinSubSteps(const VolumeSet& volumes, float3 o, float3 d, float len);

// One point along a segment's stretch through a skin cell, drawn by the grey mean of sigma_s T
// (a reservoir over the deposit's steps, then exactly within the chosen step, the extinction
// constant over it), and the estimate it gives of int sigma_s T T_cam dt over the stretch.
struct SkinPoint {
    // A step [t0, t0 + dt] of the stretch: r T at its start (per channel, r the roulette's
    // weight), the coefficients over it, and u uniform in [0, 1) for the reservoir.
    void offer(float t0, float dt, const float rT[3], Rgb sigmaS, Rgb sigmaT, float u);
    bool any() const { return mTotal > 0.0; }
    // The drawn point of the ray o + t d (u uniform in [0, 1)), and per channel the estimate
    // sigma_s r T(t) / pdf(t), to be multiplied by T_cam there.
    float3 draw(float3 o, float3 d, float u, float estimate[3]) const;

private:
    double mTotal = 0.0;
    float mT0 = 0.0f, mDt = 0.0f, mQ = 0.0f;
    float mRT[3] = {0, 0, 0};
    Rgb mSigmaS = splat(0.0f), mSigmaT = splat(0.0f);
};

// Replaces each skin cell's numerators in `grid` (as deposited: W, see above) by its camera-
// weighted mean (W/m^2): the numerators and denominators of the skin cells within kSkinRadius
// cells summed with tent weights, then divided. scratch: any buffer (resized to the skin cells').
void resolveSkinCells(const SkinCells& skin, wkb::RadianceGrid& grid, std::vector<float>& scratch);

}  // namespace nimbus::vrl
