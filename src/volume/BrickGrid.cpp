#include "BrickGrid.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstring>

#include <algorithm>
#include <cmath>

namespace nimbus {

namespace {
inline int floorDiv(int a, int b)
{
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}
}  // namespace

void BrickGrid::reset(Int3 brickLo, Int3 dims, int channels)
{
    mBrickLo = brickLo;
    mDims = {std::max(dims.x, 0), std::max(dims.y, 0), std::max(dims.z, 0)};
    mChannels = channels;
    mTable.assign(size_t(mDims.x) * mDims.y * mDims.z, -1);
    mMajorant.assign(mTable.size(), 0.0f);
    mOccupied.assign(mTable.size(), -1);
    mPool.clear();
    mBrickCount = 0;
    mMaxValue = 0.0f;
    mActiveBounds = Bbox();
}

float* BrickGrid::allocateBrick(int bx, int by, int bz)
{
    size_t slot = (size_t(bz) * mDims.y + by) * mDims.x + bx;
    if (mTable[slot] < 0) {
        mTable[slot] = int32_t(mBrickCount++);
        mPool.resize(mBrickCount * kBrickValues * mChannels, 0.0f);
    }
    return mPool.data() + size_t(mTable[slot]) * kBrickValues * mChannels;
}

void BrickGrid::allocateUnfilledBricks(const std::vector<uint64_t>& slots)
{
    for (uint64_t slot : slots)
        mTable[slot] = int32_t(mBrickCount++);
    mPool.resize(mBrickCount * kBrickValues * mChannels);  // BulkVector: not zeroed
}

namespace {

// Each brick's largest value (channel max, 0 at least), and whether any value is non-zero.
struct BrickScan {
    std::vector<float> max;
    std::vector<char> nonZero;
};

BrickScan scanBricks(const float* pool, size_t bricks, size_t valuesPerBrick)
{
    BrickScan scan;
    scan.max.resize(bricks);
    scan.nonZero.resize(bricks);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, bricks, 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t b = r.begin(); b != r.end(); ++b) {
            const float* v = pool + b * valuesPerBrick;
            float m = 0.0f;
            bool any = false;
            for (size_t i = 0; i < valuesPerBrick; ++i) {
                m = std::max(m, v[i]);
                any |= v[i] != 0.0f;
            }
            scan.max[b] = m;
            scan.nonZero[b] = any;
        }
    });
    return scan;
}

}  // namespace

void BrickGrid::updateMajorants()
{
    setMajorants(scanBricks(mPool.data(), mBrickCount, size_t(kBrickValues) * mChannels).max);
}

void BrickGrid::setMajorants(const std::vector<float>& brickMax)
{
    mMaxValue = 0.0f;
    for (size_t s = 0; s < mTable.size(); ++s) {
        const float m = mTable[s] >= 0 ? brickMax[size_t(mTable[s])] : 0.0f;
        mMajorant[s] = m;
        mOccupied[s] = m > 0.0f ? mTable[s] : -1;
        mMaxValue = std::max(mMaxValue, m);
    }
    updateActiveBounds();
}

void BrickGrid::pruneZeroBricks()
{
    const size_t n = size_t(kBrickValues) * mChannels;
    const BrickScan scan = scanBricks(mPool.data(), mBrickCount, n);
    std::vector<int32_t*> kept;  // table entries of non-zero bricks, in table order
    kept.reserve(mBrickCount);
    bool ascending = true;
    for (auto& entry : mTable) {
        if (entry < 0)
            continue;
        if (!scan.nonZero[size_t(entry)]) {
            entry = -1;
            continue;
        }
        ascending = ascending && (kept.empty() || entry > *kept.back());
        kept.push_back(&entry);
    }
    std::vector<float> brickMax(kept.size());
    if (ascending) {
        // Pool order follows table order (bricks allocated by ascending slot, as the loaders
        // do): compact in place, each brick moving down or staying, no second pool.
        for (size_t k = 0; k < kept.size(); ++k) {
            brickMax[k] = scan.max[size_t(*kept[k])];
            if (size_t(*kept[k]) != k)
                std::memmove(mPool.data() + k * n, mPool.data() + size_t(*kept[k]) * n, n * sizeof(float));
            *kept[k] = int32_t(k);
        }
        mPool.resize(kept.size() * n);
    } else {
        BulkVector<float> pool(kept.size() * n);
        for (size_t k = 0; k < kept.size(); ++k) {
            brickMax[k] = scan.max[size_t(*kept[k])];
            std::copy_n(mPool.data() + size_t(*kept[k]) * n, n, pool.data() + k * n);
            *kept[k] = int32_t(k);
        }
        mPool.swap(pool);
    }
    mBrickCount = kept.size();
    setMajorants(brickMax);
}

size_t BrickGrid::memoryBytes() const
{
    return mPool.size() * sizeof(float) + mTable.size() * (sizeof(int32_t) + sizeof(float));
}

void BrickGrid::updateActiveBounds()
{
    Bbox b;
    mBrickOrigins.assign(mBrickCount, Int3{});
    // One pass over the table's slots, coordinates only for the allocated ones: a table can be
    // mostly empty (two bricks far apart span millions of slots; fuzz_vdb: 2 bricks in a table of
    // 135 MiB, whose three nested loops took 86 s in the instrumented harness).
    const size_t dx = size_t(mDims.x), dxy = dx * size_t(mDims.y);
    for (size_t slot = 0; slot < mTable.size(); ++slot) {
        const int32_t brick = mTable[slot];
        if (brick < 0)
            continue;
        const Int3 origin{(mBrickLo.x + int(slot % dx)) * kBrick, (mBrickLo.y + int(slot % dxy / dx)) * kBrick,
                          (mBrickLo.z + int(slot / dxy)) * kBrick};
        mBrickOrigins[brick] = origin;
        const float3 lo = make_float3(float(origin.x), float(origin.y), float(origin.z));
        b.expand(lo);
        b.expand(lo + splat(float(kBrick)));  // the apron voxel at lo + 8
    }
    mActiveBounds = b;
}

int BrickGrid::slotOf(int bx, int by, int bz) const
{
    bx -= mBrickLo.x, by -= mBrickLo.y, bz -= mBrickLo.z;
    if (bx < 0 || by < 0 || bz < 0 || bx >= mDims.x || by >= mDims.y || bz >= mDims.z)
        return -1;
    return (bz * mDims.y + by) * mDims.x + bx;
}

float BrickGrid::voxel(int i, int j, int k, int c) const
{
    int slot = slotOf(floorDiv(i, kBrick), floorDiv(j, kBrick), floorDiv(k, kBrick));
    if (slot < 0 || mTable[slot] < 0)
        return 0.0f;
    int li = i - floorDiv(i, kBrick) * kBrick, lj = j - floorDiv(j, kBrick) * kBrick,
        lk = k - floorDiv(k, kBrick) * kBrick;
    const float* v = mPool.data() + size_t(mTable[slot]) * kBrickValues * mChannels;
    return v[((lk * kStored + lj) * kStored + li) * mChannels + c];
}

float BrickGrid::sample(float3 p, int c) const
{
    return interpolate(stencil(p), c);
}

BrickGrid BrickGrid::sameTopologyUnfilled(int channels) const
{
    BrickGrid g;
    g.mBrickLo = mBrickLo, g.mDims = mDims, g.mChannels = channels;
    g.mTable = mTable, g.mMajorant = mMajorant, g.mOccupied = mOccupied;
    g.mBrickCount = mBrickCount, g.mMaxValue = mMaxValue;
    g.mActiveBounds = mActiveBounds, g.mBrickOrigins = mBrickOrigins;
    g.mPool.resize(mBrickCount * kBrickValues * size_t(channels));  // neither zeroed nor a copy of ours
    return g;
}

float3 BrickGrid::sample3(float3 p) const
{
    if (mChannels == 1) {
        float v = sample(p, 0);
        return make_float3(v, v, v);
    }
    return make_float3(sample(p, 0), sample(p, 1), sample(p, 2));
}

float BrickGrid::majorantAt(float3 p, Int3* slotLo) const
{
    if (!(std::fabs(p.x) < 1e9f && std::fabs(p.y) < 1e9f && std::fabs(p.z) < 1e9f))
        return 0.0f;
    int bx = floorToInt(p.x) >> kBrickLog2, by = floorToInt(p.y) >> kBrickLog2, bz = floorToInt(p.z) >> kBrickLog2;
    if (slotLo)
        *slotLo = {bx * kBrick, by * kBrick, bz * kBrick};
    int slot = slotOf(bx, by, bz);
    return slot < 0 ? 0.0f : mMajorant[slot];
}

}  // namespace nimbus
