#include "CellReach.h"

#include <algorithm>
#include <cmath>

namespace nimbus::vrl {

std::vector<uint8_t> cellReach(const VolumeSet& volumes, const wkb::RadianceGrid& grid, int reach)
{
    const int n[3] = {grid.size(0), grid.size(1), grid.size(2)};
    std::vector<uint8_t> cls(grid.cellCount(), kCellUnread);
    const float inv = 1.0f / grid.cellSize();
    const float3 lo = grid.box().lo;
    // Marks the cells a world box overlaps as holding medium.
    auto mark = [&](float3 a, float3 b) {
        const float av[3] = {a.x, a.y, a.z}, bv[3] = {b.x, b.y, b.z}, lv[3] = {lo.x, lo.y, lo.z};
        int i0[3], i1[3];
        for (int k = 0; k < 3; ++k) {
            i0[k] = std::max(0, int(std::floor((av[k] - lv[k]) * inv)));
            i1[k] = std::min(n[k] - 1, int(std::floor((bv[k] - lv[k]) * inv)));
            if (i1[k] < i0[k])
                return;
        }
        for (int z = i0[2]; z <= i1[2]; ++z)
            for (int y = i0[1]; y <= i1[1]; ++y)
                for (int x = i0[0]; x <= i1[0]; ++x)
                    cls[(size_t(z) * size_t(n[1]) + size_t(y)) * size_t(n[0]) + size_t(x)] = kCellMedium;
    };
    constexpr int S = BrickGrid::kStored;
    for (const auto& vp : volumes.volumes()) {
        const VolumeData& v = *vp;
        const BrickGrid& g = v.density;
        // World half-extent of an index-space box of half-side 1 (the transform is affine).
        const float3 ax = v.worldFromIndex.vector(make_float3(1, 0, 0)),
                     ay = v.worldFromIndex.vector(make_float3(0, 1, 0)),
                     az = v.worldFromIndex.vector(make_float3(0, 0, 1));
        const float3 half = make_float3(std::fabs(ax.x) + std::fabs(ay.x) + std::fabs(az.x),
                                        std::fabs(ax.y) + std::fabs(ay.y) + std::fabs(az.y),
                                        std::fabs(ax.z) + std::fabs(ay.z) + std::fabs(az.z));
        // Voxel by voxel where a brick spans more than two cells, else the brick as a whole.
        const bool perVoxel =
            float(BrickGrid::kBrick) * std::fmax(half.x, std::fmax(half.y, half.z)) > 2.0f * grid.cellSize();
        for (size_t b = 0; b < g.brickCount(); ++b) {
            const float* q = g.brickData(int(b));
            const int channels = g.channels();
            const Int3 o = g.brickOrigin(b);
            bool any = false;
            for (int k = 0; k < S && (perVoxel || !any); ++k)
                for (int j = 0; j < S && (perVoxel || !any); ++j)
                    for (int i = 0; i < S; ++i) {
                        if (q[((k * S + j) * S + i) * channels] == 0.0f)
                            continue;
                        any = true;
                        if (!perVoxel)
                            break;
                        const float3 c =
                            v.worldFromIndex.point(make_float3(float(o.x + i), float(o.y + j), float(o.z + k)));
                        mark(c - half, c + half);
                    }
            if (any && !perVoxel) {
                // The brick's values span index o .. o + kBrick; the support one more each side.
                const float3 c = v.worldFromIndex.point(make_float3(float(o.x), float(o.y), float(o.z)) +
                                                        splat(0.5f * float(BrickGrid::kBrick)));
                mark(c - half * (0.5f * float(BrickGrid::kBrick) + 1.0f),
                     c + half * (0.5f * float(BrickGrid::kBrick) + 1.0f));
            }
        }
    }
    // Dilate: a cell within `reach` cells of one holding medium is read.
    std::vector<uint8_t> near(cls.size(), 0);
    for (size_t i = 0; i < cls.size(); ++i)
        near[i] = cls[i] == kCellMedium;
    const size_t stride[3] = {1, size_t(n[0]), size_t(n[0]) * size_t(n[1])};
    std::vector<uint8_t> next(near.size());
    for (int axis = 0; axis < 3; ++axis) {
        for (int z = 0; z < n[2]; ++z)
            for (int y = 0; y < n[1]; ++y)
                for (int x = 0; x < n[0]; ++x) {
                    const int c[3] = {x, y, z};
                    const size_t i = size_t(z) * stride[2] + size_t(y) * stride[1] + size_t(x);
                    uint8_t m = 0;
                    for (int r = -reach; r <= reach && !m; ++r) {
                        const int e = c[axis] + r;
                        if (e >= 0 && e < n[axis])
                            m = near[size_t(std::ptrdiff_t(i) + std::ptrdiff_t(r) * std::ptrdiff_t(stride[axis]))];
                    }
                    next[i] = m;
                }
        near.swap(next);
    }
    for (size_t i = 0; i < cls.size(); ++i)
        if (cls[i] != kCellMedium && near[i])
            cls[i] = kCellClear;
    return cls;
}

}  // namespace nimbus::vrl
