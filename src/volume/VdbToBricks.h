// VdbToBricks.h: an OpenVDB grid converted to the BrickGrid the integrators sample.
//
// Conversion: a BrickGrid brick holds voxels [8b, 8b + 8] per axis, i.e. its own 8^3 cells and
// an apron of the next brick's first voxels, so that a trilinear lookup touches one brick. The
// bricks needed are those under active leaves and active tiles and, for the apron, their
// neighbours at -1; they are enumerated from the tree's nodes and tiles, never by scanning the
// bounding box. Every stored value is read through a ValueAccessor, which resolves tiles the
// same way as leaf voxels, so a grid stored as active tiles converts to exactly the same bricks
// as its voxelised copy. Inactive values count as 0, whatever the background.
// Apart from reading files: generated, plugin and shaded grids convert the same way.
#pragma once

#include "BrickGrid.h"

#include <openvdb/openvdb.h>

#include <cstdint>
#include <string>

namespace nimbus {

// The most bricks of 8^3 voxels a volume may have: beyond it the bricks alone would need more
// than ~6 GB, which no scene on this class of machine can afford.
constexpr uint64_t kMaxBricks = uint64_t(1) << 21;

// The bricks of `grid`'s active values, `channels` floats per voxel (1 for a float grid, 3 for
// a vec3s one). Throws InputError, prefixed by `where`, when the active region is too large for
// the brick table or the brick pool, or when the pool would take more than limitBytes (the
// render.memory_limit, checked before the pool is allocated). Instantiated for
// openvdb::FloatGrid and openvdb::Vec3SGrid.
template <class GridT>
BrickGrid toBricks(const GridT& grid, int channels, const std::string& where, size_t limitBytes = SIZE_MAX);

}  // namespace nimbus
