// CellReach.h: which cells of the radiance cache (wkb/RadianceGrid.h) hold medium, and which of
// the empty ones a read of the cache can reach.
//
// The cache is read only where sigma_s > 0 (the camera's march and the pilot rays weight each read
// by it), trilinearly between cell centres, after the blur. So a cell's value is used only if it
// lies within `reach` cells (Chebyshev distance: 1 for the trilinear read, plus one per blur pass)
// of a cell that holds medium; the rest are never read, and a light path's deposit there is work
// thrown away. And a cell that holds no medium has no extinction: a deposit crosses it with T
// unchanged, and needs no medium lookups. On the clouds of the validation suite about 40% of the
// deposits' steps were in empty space (2026-12-07).
//
// A voxel v of density (index space) makes the trilinear density nonzero only within the open
// box (v - 1, v + 1), so a cell holds medium where such a box of a nonzero voxel overlaps it (a
// conservative test: a cell marked clear has density 0 everywhere inside it).
#pragma once

#include "../render/VolumeSet.h"
#include "../wkb/RadianceGrid.h"

#include <cstdint>
#include <vector>

namespace nimbus::vrl {

enum CellReach : uint8_t {
    kCellUnread = 0,  // no medium within `reach` cells: never read
    kCellClear = 1,   // no medium in the cell, but read (directly or through the blur)
    kCellMedium = 2,  // some medium in the cell
};

// One entry per cell of `grid`, in its cell order.
std::vector<uint8_t> cellReach(const VolumeSet& volumes, const wkb::RadianceGrid& grid, int reach);

}  // namespace nimbus::vrl
