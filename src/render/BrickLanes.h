// BrickLanes.h: BrickGrid lookups for eight points at once, one per AVX2 lane.
//
// The eight-ray marches (MarchEightRays.cpp, camera rays; MarchParallelRays.cpp, shadow-map
// texel rays) place each lane's sample by its own index-space position rather than by a DDA:
// the brick under it from the occupancy table, then the trilinear stencil inside that brick,
// as BrickGrid::occupiedBrick and BrickWalk.h's walk compute them one point at a time.
#pragma once

#if defined(__AVX2__) && defined(__FMA__)

#include "../volume/BrickGrid.h"

#include <immintrin.h>

namespace nimbus::lanes {

inline bool none(__m256 mask)
{
    return _mm256_movemask_ps(mask) == 0;
}

// The occupied brick under eight index-space points, and the points' cells (index / 8, floored).
struct BrickTable {
    explicit BrickTable(const BrickGrid& grid)
        : occupied(grid.occupiedTable().data()), loX(_mm256_set1_epi32(grid.brickLo().x)),
          loY(_mm256_set1_epi32(grid.brickLo().y)), loZ(_mm256_set1_epi32(grid.brickLo().z)),
          dimX(_mm256_set1_epi32(grid.dims().x)), dimY(_mm256_set1_epi32(grid.dims().y)),
          dimZ(_mm256_set1_epi32(grid.dims().z))
    {
    }
    // The brick index where `alive` and the point's brick is occupied, else -1 (outside the
    // table too, as BrickGrid::occupiedBrick); cell* receive the brick coordinates as floats.
    __m256i brickAt(__m256 qx, __m256 qy, __m256 qz, __m256 alive, __m256& cellX, __m256& cellY, __m256& cellZ) const
    {
        const __m256 eighth = _mm256_set1_ps(1.0f / float(BrickGrid::kBrick));
        cellX = _mm256_floor_ps(_mm256_mul_ps(qx, eighth));  // (exact: 1/8 is a power of two)
        cellY = _mm256_floor_ps(_mm256_mul_ps(qy, eighth));
        cellZ = _mm256_floor_ps(_mm256_mul_ps(qz, eighth));
        const __m256i bx = _mm256_sub_epi32(_mm256_cvttps_epi32(cellX), loX);
        const __m256i by = _mm256_sub_epi32(_mm256_cvttps_epi32(cellY), loY);
        const __m256i bz = _mm256_sub_epi32(_mm256_cvttps_epi32(cellZ), loZ);
        const __m256i zero = _mm256_setzero_si256();
        auto within = [&](__m256i v, __m256i dim) {
            return _mm256_andnot_si256(_mm256_cmpgt_epi32(zero, v), _mm256_cmpgt_epi32(dim, v));
        };
        const __m256i inTable =
            _mm256_and_si256(_mm256_castps_si256(alive),
                             _mm256_and_si256(within(bx, dimX), _mm256_and_si256(within(by, dimY), within(bz, dimZ))));
        const __m256i slot = _mm256_and_si256(
            inTable,
            _mm256_add_epi32(_mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(bz, dimY), by), dimX), bx));
        return _mm256_mask_i32gather_epi32(_mm256_set1_epi32(-1), occupied, slot, inTable, 4);
    }

    const int32_t* occupied;
    __m256i loX, loY, loZ, dimX, dimY, dimZ;
};

// Where a trilinear lookup reads in the bricks of lanes `inBrick`: the index of the cell's lower
// corner in the pool (brick * 9^3 + corner; 0 in other lanes, a valid value to gather and mask
// out) and the weights, from the point's position relative to its brick, clamped into [0, 8)
// against rounding (BrickWalk.h's clampLocal).
struct Stencil8 {
    __m256i index;
    __m256 tx, ty, tz;
};
inline Stencil8 stencilAt(__m256i brick, __m256 inBrick, __m256 qx, __m256 qy, __m256 qz, __m256 cellX, __m256 cellY,
                          __m256 cellZ)
{
    constexpr float B = float(BrickGrid::kBrick);
    const __m256 side = _mm256_set1_ps(B), zero = _mm256_setzero_ps();
    const __m256 lastInside = _mm256_set1_ps(B * (1.0f - 1.0f / 16777216.0f));  // largest float below 8
    auto local = [&](__m256 q, __m256 cell) {
        return _mm256_min_ps(_mm256_max_ps(_mm256_fnmadd_ps(cell, side, q), zero), lastInside);
    };
    const __m256 lx = local(qx, cellX), ly = local(qy, cellY), lz = local(qz, cellZ);
    const __m256 fx = _mm256_floor_ps(lx), fy = _mm256_floor_ps(ly), fz = _mm256_floor_ps(lz);
    const __m256i stored = _mm256_set1_epi32(BrickGrid::kStored);
    const __m256i corner = _mm256_add_epi32(
        _mm256_mullo_epi32(
            _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(fz), stored), _mm256_cvttps_epi32(fy)), stored),
        _mm256_cvttps_epi32(fx));
    const __m256i index =
        _mm256_add_epi32(_mm256_mullo_epi32(brick, _mm256_set1_epi32(BrickGrid::kBrickValues)), corner);
    return {_mm256_and_si256(_mm256_castps_si256(inBrick), index), _mm256_sub_ps(lx, fx), _mm256_sub_ps(ly, fy),
            _mm256_sub_ps(lz, fz)};
}

// BrickGrid::trilinear<1> at eight stencils of a one-channel pool.
inline __m256 trilinear(const float* pool, const Stencil8& s)
{
    constexpr int sy = BrickGrid::kStored, sz = BrickGrid::kStored * BrickGrid::kStored;
    auto lerp = [](__m256 a, __m256 b, __m256 w) { return _mm256_fmadd_ps(w, _mm256_sub_ps(b, a), a); };
    auto at = [&](int offset) { return _mm256_i32gather_ps(pool + offset, s.index, 4); };
    const __m256 c0 = lerp(lerp(at(0), at(1), s.tx), lerp(at(sy), at(sy + 1), s.tx), s.ty);
    const __m256 c1 = lerp(lerp(at(sz), at(sz + 1), s.tx), lerp(at(sz + sy), at(sz + sy + 1), s.tx), s.ty);
    return lerp(c0, c1, s.tz);
}

// Whether a pool's gathers can address it with 32-bit indices.
inline bool gatherable(const BrickGrid& grid)
{
    return grid.pool().size() + size_t(BrickGrid::kBrickValues) < size_t(INT32_MAX);
}

}  // namespace nimbus::lanes

#endif
