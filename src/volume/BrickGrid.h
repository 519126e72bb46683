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

#include "../core/BulkAllocator.h"
#include "../core/Transform.h"
#include "../core/Vec.h"

#include <cmath>
#include <cstdint>
#include <vector>

namespace nimbus {

class BrickGrid {
public:
    static constexpr int kBrickLog2 = 3;
    static constexpr int kBrick = 1 << kBrickLog2;  // cells per brick side
    static constexpr int kStored = kBrick + 1;      // values per side including the apron
    static constexpr int kBrickValues = kStored * kStored * kStored;

    BrickGrid() = default;

    // Allocates an empty grid whose table covers bricks [brickLo, brickLo + dims).
    void reset(Int3 brickLo, Int3 dims, int channels);
    // Allocates storage for slot (bx,by,bz) in table coordinates; returns its value pointer
    // (kBrickValues * channels floats, x fastest, channel innermost), zero-filled.
    float* allocateBrick(int bx, int by, int bz);
    // Allocates the bricks at these table slots ((bz * dims.y + by) * dims.x + bx, ascending,
    // none allocated yet) without initialising their values: the caller writes every value
    // of every one (brickValues), typically in parallel, so their pages are first touched there.
    void allocateUnfilledBricks(const std::vector<uint64_t>& slots);
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

    // Where a trilinear lookup at index position p reads: the brick and the cell's corner inside
    // it, plus the weights. Grids that share this grid's topology (sameTopologyUnfilled) can be read
    // through the same stencil, so several quantities on one lattice cost one address
    // computation (density and baked light transmittance in the single-scattering march).
    struct Stencil {
        int32_t brick = -1;  // -1: outside every allocated brick, all grids read 0
        int32_t corner = 0;  // index of the cell's lower corner among the brick's 9^3 values
        float tx = 0, ty = 0, tz = 0;
    };
    Stencil stencil(float3 p) const
    {
        Stencil s;
        if (!(p.x > -1e9f && p.x < 1e9f && p.y > -1e9f && p.y < 1e9f && p.z > -1e9f && p.z < 1e9f))
            return s;
        int i = floorToInt(p.x), j = floorToInt(p.y), k = floorToInt(p.z);
        float fx = float(i), fy = float(j), fz = float(k);
        int bx = (i >> kBrickLog2) - mBrickLo.x, by = (j >> kBrickLog2) - mBrickLo.y,
            bz = (k >> kBrickLog2) - mBrickLo.z;
        if (unsigned(bx) >= unsigned(mDims.x) || unsigned(by) >= unsigned(mDims.y) || unsigned(bz) >= unsigned(mDims.z))
            return s;
        s.brick = mTable[(size_t(bz) * mDims.y + by) * mDims.x + bx];
        if (s.brick < 0)
            return s;
        s.corner = ((k & (kBrick - 1)) * kStored + (j & (kBrick - 1))) * kStored + (i & (kBrick - 1));
        s.tx = p.x - fx, s.ty = p.y - fy, s.tz = p.z - fz;
        return s;
    }
    float interpolate(const Stencil& s, int c = 0) const
    {
        if (s.brick < 0)
            return 0.0f;
        const int sx = mChannels, sy = kStored * mChannels, sz = kStored * kStored * mChannels;
        const float* q = mPool.data() + (size_t(s.brick) * kBrickValues + s.corner) * mChannels + c;
        float c00 = q[0] + s.tx * (q[sx] - q[0]);
        float c10 = q[sy] + s.tx * (q[sy + sx] - q[sy]);
        float c01 = q[sz] + s.tx * (q[sz + sx] - q[sz]);
        float c11 = q[sz + sy] + s.tx * (q[sz + sy + sx] - q[sz + sy]);
        float c0 = c00 + s.ty * (c10 - c00);
        float c1 = c01 + s.ty * (c11 - c01);
        return c0 + s.tz * (c1 - c0);
    }
    // Trilinear interpolation inside one brick's values, for a grid of `Channels` channels known
    // at compile time (the strides become constants): q points at channel c of the cell's
    // lower corner, brickData(b) + corner * Channels + c. The inner loop of the marchers.
    template <int Channels>
    static float trilinear(const float* q, float tx, float ty, float tz)
    {
        constexpr int sx = Channels, sy = kStored * Channels, sz = kStored * kStored * Channels;
        float c00 = q[0] + tx * (q[sx] - q[0]);
        float c10 = q[sy] + tx * (q[sy + sx] - q[sy]);
        float c01 = q[sz] + tx * (q[sz + sx] - q[sz]);
        float c11 = q[sz + sy] + tx * (q[sz + sy + sx] - q[sz + sy]);
        float c0 = c00 + ty * (c10 - c00);
        float c1 = c01 + ty * (c11 - c01);
        return c0 + tz * (c1 - c0);
    }
    // The allocated brick at brick coordinates (bx, by, bz) (index / 8, not relative to
    // brickLo), or -1 where the slot is outside the table, unallocated or all zero.
    int occupiedBrick(int bx, int by, int bz) const
    {
        bx -= mBrickLo.x, by -= mBrickLo.y, bz -= mBrickLo.z;
        if (unsigned(bx) >= unsigned(mDims.x) || unsigned(by) >= unsigned(mDims.y) || unsigned(bz) >= unsigned(mDims.z))
            return -1;
        return mOccupied[(size_t(bz) * mDims.y + by) * mDims.x + bx];
    }
    // The allocated brick at brick coordinates (bx, by, bz), occupied or not, or -1.
    int allocatedBrick(int bx, int by, int bz) const
    {
        bx -= mBrickLo.x, by -= mBrickLo.y, bz -= mBrickLo.z;
        if (unsigned(bx) >= unsigned(mDims.x) || unsigned(by) >= unsigned(mDims.y) || unsigned(bz) >= unsigned(mDims.z))
            return -1;
        return mTable[(size_t(bz) * mDims.y + by) * mDims.x + bx];
    }
    // Values of allocated brick b (kBrickValues * channels floats, x fastest, channel innermost).
    const float* brickData(int b) const { return mPool.data() + size_t(b) * kBrickValues * mChannels; }

    // A grid with this grid's bricks and table and room for its own values (`channels` each),
    // not initialised: the caller writes every value of every brick (LightCache::bake).
    BrickGrid sameTopologyUnfilled(int channels) const;
    // Writable values of allocated brick b (kBrickValues * channels floats).
    float* brickValues(size_t b) { return mPool.data() + b * kBrickValues * mChannels; }
    // Index-space position of the lower corner of allocated brick b.
    Int3 brickOrigin(size_t b) const { return mBrickOrigins[b]; }

    // The majorant of the slot containing index position p (0 for empty or outside), and the
    // slot's index bounds [lo, lo + 8) for DDA / skipping.
    float majorantAt(float3 p, Int3* slotLo = nullptr) const;
    float maxValue() const { return mMaxValue; }

    // Flat arrays (for OpenCL upload and tests).
    const std::vector<int32_t>& table() const { return mTable; }
    // Per slot, as occupiedBrick: the brick index where the majorant is positive, else -1.
    const std::vector<int32_t>& occupiedTable() const { return mOccupied; }
    const BulkVector<float>& pool() const { return mPool; }
    const std::vector<float>& majorants() const { return mMajorant; }  // per slot, channel max

private:
    int slotOf(int bx, int by, int bz) const;  // -1 if outside the table
    void updateActiveBounds();
    // Slot majorants, occupancy and the maximum from each allocated brick's maximum.
    void setMajorants(const std::vector<float>& brickMax);

    Int3 mBrickLo, mDims;
    int mChannels = 1;
    std::vector<int32_t> mTable;     // slot -> brick index or -1
    BulkVector<float> mPool;         // brick values
    std::vector<float> mMajorant;    // slot -> max over channels of the brick's values
    std::vector<int32_t> mOccupied;  // slot -> brick index where the majorant is positive, else -1
    size_t mBrickCount = 0;
    float mMaxValue = 0.0f;
    Bbox mActiveBounds;
    std::vector<Int3> mBrickOrigins;  // per allocated brick, filled by updateMajorants
};

}  // namespace nimbus
