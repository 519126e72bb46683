// BrickGrid.h: nimbus's own sparse voxel grid, the one every integrator samples.
//
// Design: OpenVDB is the interchange format; its headers cost ~25 s per translation unit, and its
// accessors are not usable from OpenCL. So each VDB grid is converted once (VdbLoad.cpp) into
// bricks of 8^3 cells aligned with VDB leaf nodes, stored with a one-voxel apron (9^3 values),
// so a trilinear lookup touches exactly one brick. A dense table of brick slots covers the
// active bounding box at 1/8 resolution; empty slots (-1) read as zero. Each slot keeps the
// maximum of its 9^3 values: trilinear interpolation never exceeds the largest corner, so it is
// an exact local majorant for delta tracking and a cheap test for empty-space skipping.
// The same three arrays are uploaded to OpenCL unchanged (flat buffers).
//
// Index space follows OpenVDB: voxel (i,j,k) has its centre at integer coordinates.
#pragma once

#include "../core/Transform.h"
#include "../core/Vec.h"

#include <cstdint>
#include <vector>

namespace nimbus {

class BrickGrid {
public:
    static constexpr int kBrickLog2 = 3;
    static constexpr int kBrick = 1 << kBrickLog2;  // cells per brick side
    static constexpr int kStored = kBrick + 1;       // values per side including the apron
    static constexpr int kBrickValues = kStored * kStored * kStored;

    BrickGrid() = default;

    // Allocates an empty grid whose table covers bricks [brickLo, brickLo + dims).
    void reset(Int3 brickLo, Int3 dims, int channels);
    // Allocates storage for slot (bx,by,bz) in table coordinates; returns its value pointer
    // (kBrickValues * channels floats, x fastest, channel innermost), zero-filled.
    float* allocateBrick(int bx, int by, int bz);
    // Recomputes every slot's majorant from its stored values (after filling).
    void updateMajorants();
    // Frees bricks whose values are all zero.
    void pruneZeroBricks();

    int channels() const { return mChannels; }
    bool empty() const { return mBrickCount == 0; }
    size_t brickCount() const { return mBrickCount; }
    size_t memoryBytes() const;

    // Index-space bounds of the table (voxel centres), and of the allocated bricks.
    Int3 brickLo() const { return mBrickLo; }
    Int3 dims() const { return mDims; }
    const Bbox& activeIndexBounds() const { return mActiveBounds; }  // cached by updateMajorants

    // Trilinear sample of channel c at index-space position p (zero outside).
    float sample(float3 p, int c = 0) const;
    // All channels (up to 3) at once.
    float3 sample3(float3 p) const;
    // Nearest stored value at voxel (i, j, k).
    float voxel(int i, int j, int k, int c = 0) const;

    // The majorant of the slot containing index position p (0 for empty or outside), and the
    // slot's index bounds [lo, lo + 8) for DDA / skipping.
    float majorantAt(float3 p, Int3* slotLo = nullptr) const;
    float maxValue() const { return mMaxValue; }

    // Flat arrays (for OpenCL upload and tests).
    const std::vector<int32_t>& table() const { return mTable; }
    const std::vector<float>& pool() const { return mPool; }
    const std::vector<float>& majorants() const { return mMajorant; }  // per slot, channel max

private:
    int slotOf(int bx, int by, int bz) const;  // -1 if outside the table
    void updateActiveBounds();

    Int3 mBrickLo, mDims;
    int mChannels = 1;
    std::vector<int32_t> mTable;   // slot -> brick index or -1
    std::vector<float> mPool;      // brick values
    std::vector<float> mMajorant;  // slot -> max over channels of the brick's values
    size_t mBrickCount = 0;
    float mMaxValue = 0.0f;
    Bbox mActiveBounds;
};

}  // namespace nimbus
