// StiffVoxels.h: where a voxel is optically thick, and the light's optical depth there.
//
// The camera march reads each light's optical depth tau_L from the voxel lattice (LightCache)
// by trilinear interpolation. That is exact where tau_L is linear across a cell, which holds
// where the density is (nearly) constant in the cell. Inside a cell whose density changes by
// delta_rho, tau_L along the light is quadratic, and linear interpolation errs by up to
// sigma_t h delta_rho / 8 (h the voxel edge). At a voxelised surface (a one-voxel density ramp
// from 0 to 1) of a medium with sigma_t h = 18.75, that is 2.3 in optical depth exactly where
// the camera sees (tau_camera ~ 1 lies a quarter voxel in): L1 came out 86% dark.
//
// Such cells are found once per render, per brick (`StiffVoxels::find`); there the light's
// optical depth is marched back toward the light from the sample point itself, through the
// cells' own trilinear density (exact: along a line a trilinear cell is a cubic, which
// Simpson's rule integrates exactly), until a cell where the lattice interpolation is exact
// again (flat: sigma_t h delta_rho < kFlatCell) supplies the rest, d tau_L / ds = sigma_t rho
// (Tessendorf eq. 27). The camera's steps through those bricks are split so that each carries
// an optical depth of at most kSubStepDepth (SingleScatter.cpp, the secant rule).
#pragma once

#include "../volume/VolumeData.h"

#include <cstdint>
#include <vector>

namespace nimbus {

// A cell whose optical-depth contrast sigma_t h (rho_max - rho_min) is below this is flat: the
// trilinear tau_L is within kFlatCell / 8 = 0.0125 of the true one (1.25% in transmittance).
constexpr float kFlatCell = 0.1f;
// A brick is stiff (its camera steps sub-stepped, its tau_L marched back) where a cell's
// optical-depth contrast reaches kStiffCell or a camera step's optical depth kStiffStep: there
// the lattice's error in tau_L (up to contrast / 8) exceeds 0.06 optical depths. Below, the
// plain march loses at most a few percent of L1 (the suites' cumuli, 0.3-0.8 per voxel: -2.5%
// and -3.1% against the path tracer, -1.4% and -1.9% when they were flagged at contrast 0.1),
// while the sub-steps' back-marches cost 20-45x the march time there (docs/single-scattering.md).
constexpr float kStiffCell = 0.5f;
constexpr float kStiffStep = 1.0f;
// The most optical depth one camera sub-step crosses in a stiff brick: the secant rule's
// bias in a one-voxel ramp is then under 0.1% (docs/single-scattering.md).
constexpr float kSubStepDepth = 0.5f;
// At most this many sub-steps per camera step (kSubStepDepth holds up to a camera step of 2048
// optical depths; the march ends a few sub-steps past the entry there, where T is below the
// tolerance).
constexpr int kMaxSubSteps = 4096;

struct StiffVoxels {
    // Per allocated brick of the density grid: 0 where the plain march is exact enough; else
    // the number of sub-steps (>= 1) a camera step of `step` metres takes there.
    std::vector<uint16_t> subSteps;
    bool any = false;  // some brick is stiff

    // The bricks of `vol` holding a cell that is not flat, or whose densest voxel makes a
    // camera step of `step` metres thicker than kSubStepDepth.
    static StiffVoxels find(const VolumeData& vol, float step);

    int subStepsOf(int brick) const { return brick >= 0 && !subSteps.empty() ? subSteps[size_t(brick)] : 0; }
};

// The optical depth from a light to index-space point p of `vol`, per channel (cache's
// channels; a grey cache answers in .x, .y, .z alike): marched back from p along `toLight`
// (index units per world metre, the index-space image of the unit world direction toward the
// light) through cells that are not flat, for at most `maxDistance` metres (the light's
// distance: beyond it there is nothing), then the lattice's value where the march stops.
Rgb stiffOpticalDepth(const VolumeData& vol, const BrickGrid& cache, float3 p, float3 toLight, float maxDistance);

}  // namespace nimbus
