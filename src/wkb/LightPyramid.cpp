#include "LightPyramid.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>

namespace nimbus::wkb {

namespace {

constexpr int B = BrickGrid::kBrick;
constexpr int S = BrickGrid::kStored;
// The decimating filter: binomial, variance 1 (in the finer level's voxels).
constexpr float kTap[5] = {1.0f / 16, 4.0f / 16, 6.0f / 16, 4.0f / 16, 1.0f / 16};
// A level-k brick B needs level-(k-1) voxels [16B - 2, 16B + 18]: 21 per axis.
constexpr int kRegion = 2 * B + 5;

inline int floorDiv(int a, int b)
{
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

bool lessInt3(const Int3& a, const Int3& b)
{
    return std::tie(a.z, a.y, a.x) < std::tie(b.z, b.y, b.x);
}
bool equalInt3(const Int3& a, const Int3& b)
{
    return a.x == b.x && a.y == b.y && a.z == b.z;
}

// Allocates `grid` over the given absolute brick coordinates; returns the value pointers in the
// order of `bricks` (sorted and unique on return).
std::vector<float*> allocate(BrickGrid& grid, std::vector<Int3>& bricks, int channels)
{
    std::sort(bricks.begin(), bricks.end(), lessInt3);
    bricks.erase(std::unique(bricks.begin(), bricks.end(), equalInt3), bricks.end());
    Int3 lo{INT32_MAX, INT32_MAX, INT32_MAX}, hi{INT32_MIN, INT32_MIN, INT32_MIN};
    for (const Int3& b : bricks) {
        lo = {std::min(lo.x, b.x), std::min(lo.y, b.y), std::min(lo.z, b.z)};
        hi = {std::max(hi.x, b.x), std::max(hi.y, b.y), std::max(hi.z, b.z)};
    }
    if (bricks.empty())
        lo = hi = Int3{0, 0, 0};
    grid.reset(lo, {hi.x - lo.x + 1, hi.y - lo.y + 1, hi.z - lo.z + 1}, channels);
    for (const Int3& b : bricks)
        grid.allocateBrick(b.x - lo.x, b.y - lo.y, b.z - lo.z);
    // Pointers only after the last allocation (the pool grows with each).
    std::vector<float*> ptrs;
    ptrs.reserve(bricks.size());
    for (const Int3& b : bricks)
        ptrs.push_back(grid.allocateBrick(b.x - lo.x, b.y - lo.y, b.z - lo.z));
    return ptrs;
}

// The stored values of voxel (i, j, k) (all channels), or nullptr where no brick is allocated.
inline const float* voxelValues(const BrickGrid& g, int i, int j, int k)
{
    const int bx = floorDiv(i, B), by = floorDiv(j, B), bz = floorDiv(k, B);
    const Int3 lo = g.brickLo(), dims = g.dims();
    const int tx = bx - lo.x, ty = by - lo.y, tz = bz - lo.z;
    if (tx < 0 || ty < 0 || tz < 0 || tx >= dims.x || ty >= dims.y || tz >= dims.z)
        return nullptr;
    const int32_t brick = g.table()[(size_t(tz) * dims.y + ty) * dims.x + tx];
    if (brick < 0)
        return nullptr;
    const int li = i - bx * B, lj = j - by * B, lk = k - bz * B;
    return g.pool().data() + (size_t(brick) * BrickGrid::kBrickValues + size_t((lk * S + lj) * S + li)) * g.channels();
}

}  // namespace

void LightPyramid::allocateLevel0(const std::vector<Int3>& bricks, int channels)
{
    mChannels = channels;
    mLevels.assign(1, BrickGrid());
    std::vector<Int3> sorted = bricks;
    std::vector<float*> ptrs = allocate(mLevels[0], sorted, channels);
    mLevel0.clear();
    for (size_t i = 0; i < sorted.size(); ++i)
        mLevel0.push_back({sorted[i], ptrs[i]});
}

float LightPyramid::levelForSigma(float sigma)
{
    if (!(sigma > 0.0f))
        return 0.0f;
    return float(std::log(3.0 * double(sigma) * double(sigma) + 1.0) / std::log(4.0));
}

float LightPyramid::sigmaOfLevel(float k)
{
    return float(std::sqrt((std::pow(4.0, double(k)) - 1.0) / 3.0));
}

void LightPyramid::buildLevels(float maxSigma, int maxLevels, const StopFlag* stop)
{
    if (mLevels.empty())
        return;
    for (int k = 1; k < maxLevels && sigmaOfLevel(float(k - 1)) < maxSigma && !mLevels.back().empty(); ++k)
        buildLevel(k, stop);
    throwIfStopped(stop);
    for (BrickGrid& g : mLevels)
        g.updateMajorants();
}

std::vector<Int3> LightPyramid::coarserBricks(const std::vector<Int3>& fine)
{
    // The parents of the finer level's bricks. The filter's tails beyond them (up to one brick)
    // are dropped: a read divides by channel 0, which loses the same tails, so it stays a
    // weighted average of the source over a footprint clipped at the active region; keeping the
    // tails would triple the bricks per axis at every coarse level.
    std::vector<Int3> out;
    out.reserve(fine.size());
    for (const Int3& f : fine)
        out.push_back({floorDiv(f.x, 2), floorDiv(f.y, 2), floorDiv(f.z, 2)});
    std::sort(out.begin(), out.end(), lessInt3);
    out.erase(std::unique(out.begin(), out.end(), equalInt3), out.end());
    return out;
}

size_t LightPyramid::levelBytes(const std::vector<Int3>& bricks, int channels)
{
    if (bricks.empty())
        return 0;
    Int3 lo{INT32_MAX, INT32_MAX, INT32_MAX}, hi{INT32_MIN, INT32_MIN, INT32_MIN};
    for (const Int3& b : bricks) {
        lo = {std::min(lo.x, b.x), std::min(lo.y, b.y), std::min(lo.z, b.z)};
        hi = {std::max(hi.x, b.x), std::max(hi.y, b.y), std::max(hi.z, b.z)};
    }
    const size_t slots = size_t(hi.x - lo.x + 1) * size_t(hi.y - lo.y + 1) * size_t(hi.z - lo.z + 1);
    // BrickGrid::memoryBytes: the pool plus a table entry and a majorant per slot.
    return bricks.size() * BrickGrid::kBrickValues * size_t(channels) * sizeof(float) +
           slots * (sizeof(int32_t) + sizeof(float));
}

void LightPyramid::buildLevel(int k, const StopFlag* stop)
{
    const BrickGrid& fine = mLevels[k - 1];
    std::vector<Int3> fineBricks;
    const Int3 flo = fine.brickLo(), fd = fine.dims();
    for (int z = 0; z < fd.z; ++z)
        for (int y = 0; y < fd.y; ++y)
            for (int x = 0; x < fd.x; ++x)
                if (fine.table()[(size_t(z) * fd.y + y) * fd.x + x] >= 0)
                    fineBricks.push_back({flo.x + x, flo.y + y, flo.z + z});
    std::vector<Int3> bricks = coarserBricks(fineBricks);
    BrickGrid coarse;
    std::vector<float*> ptrs = allocate(coarse, bricks, mChannels);
    const int C = mChannels;

    tbb::parallel_for(tbb::blocked_range<size_t>(0, bricks.size()), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<float> src(size_t(kRegion) * kRegion * kRegion * C);
        std::vector<float> px(size_t(kRegion) * kRegion * S * C);
        std::vector<float> py(size_t(kRegion) * S * S * C);
        for (size_t bi = r.begin(); bi != r.end(); ++bi) {
            throwIfStopped(stop);
            const Int3 cb = bricks[bi];
            const int x0 = 2 * B * cb.x - 2, y0 = 2 * B * cb.y - 2, z0 = 2 * B * cb.z - 2;
            // Gather the finer level's region (zero where nothing is allocated).
            for (int z = 0; z < kRegion; ++z)
                for (int y = 0; y < kRegion; ++y)
                    for (int x = 0; x < kRegion; ++x) {
                        float* dst = src.data() + ((size_t(z) * kRegion + y) * kRegion + x) * C;
                        const float* v = voxelValues(fine, x0 + x, y0 + y, z0 + z);
                        if (v)
                            std::memcpy(dst, v, sizeof(float) * C);
                        else
                            std::fill(dst, dst + C, 0.0f);
                    }
            // Separable filter and decimation: output o reads region 2o + t, t = 0..4.
            for (int z = 0; z < kRegion; ++z)
                for (int y = 0; y < kRegion; ++y)
                    for (int o = 0; o < S; ++o) {
                        float* dst = px.data() + ((size_t(z) * kRegion + y) * S + o) * C;
                        std::fill(dst, dst + C, 0.0f);
                        for (int t = 0; t < 5; ++t) {
                            const float* s = src.data() + ((size_t(z) * kRegion + y) * kRegion + 2 * o + t) * C;
                            for (int c = 0; c < C; ++c)
                                dst[c] += kTap[t] * s[c];
                        }
                    }
            for (int z = 0; z < kRegion; ++z)
                for (int o = 0; o < S; ++o)
                    for (int x = 0; x < S; ++x) {
                        float* dst = py.data() + ((size_t(z) * S + o) * S + x) * C;
                        std::fill(dst, dst + C, 0.0f);
                        for (int t = 0; t < 5; ++t) {
                            const float* s = px.data() + ((size_t(z) * kRegion + 2 * o + t) * S + x) * C;
                            for (int c = 0; c < C; ++c)
                                dst[c] += kTap[t] * s[c];
                        }
                    }
            float* out = ptrs[bi];
            for (int o = 0; o < S; ++o)
                for (int y = 0; y < S; ++y)
                    for (int x = 0; x < S; ++x) {
                        float* dst = out + ((size_t(o) * S + y) * S + x) * C;
                        std::fill(dst, dst + C, 0.0f);
                        for (int t = 0; t < 5; ++t) {
                            const float* s = py.data() + ((size_t(2 * o + t) * S + y) * S + x) * C;
                            for (int c = 0; c < C; ++c)
                                dst[c] += kTap[t] * s[c];
                        }
                    }
        }
    });
    mLevels.push_back(std::move(coarse));
}

size_t LightPyramid::memoryBytes() const
{
    size_t bytes = 0;
    for (const BrickGrid& g : mLevels)
        bytes += g.memoryBytes();
    return bytes;
}

void LightPyramid::fetchLevel(int k, float3 p0, int c0, int n, float weight, float* out) const
{
    const BrickGrid& g = mLevels[k];
    const float inv = 1.0f / float(1 << k);
    const float px = p0.x * inv, py = p0.y * inv, pz = p0.z * inv;
    if (!(std::fabs(px) < 1e9f && std::fabs(py) < 1e9f && std::fabs(pz) < 1e9f))
        return;
    const float fx = std::floor(px), fy = std::floor(py), fz = std::floor(pz);
    const int i = int(fx), j = int(fy), kk = int(fz);
    const int bx = floorDiv(i, B), by = floorDiv(j, B), bz = floorDiv(kk, B);
    const Int3 lo = g.brickLo(), dims = g.dims();
    const int tx = bx - lo.x, ty = by - lo.y, tz = bz - lo.z;
    if (tx < 0 || ty < 0 || tz < 0 || tx >= dims.x || ty >= dims.y || tz >= dims.z)
        return;
    const int32_t brick = g.table()[(size_t(tz) * dims.y + ty) * dims.x + tx];
    if (brick < 0)
        return;
    const float wx = px - fx, wy = py - fy, wz = pz - fz;
    const int li = i - bx * B, lj = j - by * B, lk = kk - bz * B;
    const int C = g.channels();
    const float* base =
        g.pool().data() + (size_t(brick) * BrickGrid::kBrickValues + size_t((lk * S + lj) * S + li)) * C + c0;
    const size_t sx = C, sy = size_t(S) * C, sz = size_t(S) * S * C;
    const float w[8] = {
        (1 - wx) * (1 - wy) * (1 - wz), wx * (1 - wy) * (1 - wz), (1 - wx) * wy * (1 - wz), wx * wy * (1 - wz),
        (1 - wx) * (1 - wy) * wz,       wx * (1 - wy) * wz,       (1 - wx) * wy * wz,       wx * wy * wz};
    const size_t off[8] = {0, sx, sy, sx + sy, sz, sz + sx, sz + sy, sz + sy + sx};
    // Channel outermost: eight loads summed in a register per channel, one store (out may alias
    // nothing, but the compiler cannot know that across the corner loop).
    for (int c = 0; c < n; ++c) {
        const float* v = base + c;
        const float sum = w[0] * v[off[0]] + w[1] * v[off[1]] + w[2] * v[off[2]] + w[3] * v[off[3]] + w[4] * v[off[4]] +
                          w[5] * v[off[5]] + w[6] * v[off[6]] + w[7] * v[off[7]];
        out[c] += weight * sum;
    }
}

void LightPyramid::fetch(float3 p0, float sigma, int c0, int n, float weight, float* out) const
{
    if (mLevels.empty())
        return;
    const float lambda = std::min(levelForSigma(sigma), float(mLevels.size() - 1));
    const int k0 = int(lambda);
    const float t = lambda - float(k0);
    fetchLevel(k0, p0, c0, n, weight * (1.0f - t), out);
    if (t > 0.0f && k0 + 1 < int(mLevels.size()))
        fetchLevel(k0 + 1, p0, c0, n, weight * t, out);
}

}  // namespace nimbus::wkb
