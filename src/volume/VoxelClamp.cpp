// VoxelClamp.cpp: clampGrid and the one warning per volume (VoxelClamp.h).
#include "VoxelClamp.h"

#include "../core/Log.h"

#include <tbb/parallel_reduce.h>

#include <cmath>
#include <limits>

namespace nimbus {

namespace {

// Non-negative and finite: what a fog volume's values may be.
inline bool isClean(float v)
{
    return v >= 0.0f && v <= std::numeric_limits<float>::max();
}
inline bool isClean(const openvdb::Vec3s& v)
{
    return isClean(v[0]) && isClean(v[1]) && isClean(v[2]);
}

// Sets a bad value to 0 and counts it `weight` times (the voxels a tile stands for); true if
// the value changed.
inline bool clampValue(float& v, ClampCount& c, uint64_t weight)
{
    if (isClean(v))
        return false;
    (std::isnan(v) ? c.nan : std::isinf(v) ? c.infinite : c.negative) += weight;
    v = 0.0f;
    return true;
}

inline bool clampValue(openvdb::Vec3s& v, ClampCount& c, uint64_t weight)
{
    bool changed = false;
    for (int i = 0; i < 3; ++i)
        changed |= clampValue(v[i], c, weight);
    return changed;
}

}  // namespace

template <class GridT>
ClampCount clampGrid(GridT& grid)
{
    using TreeT = typename GridT::TreeType;
    using LeafT = typename TreeT::LeafNodeType;
    std::vector<LeafT*> leaves;
    grid.tree().getNodes(leaves);
    ClampCount count = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, leaves.size()), ClampCount(),
        [&](const tbb::blocked_range<size_t>& r, ClampCount c) {
            // Straight through each leaf's buffer (an iterator over active values costs ~5 ns
            // a voxel). Inactive bad values are zeroed too, uncounted: a trilinear lookup at a
            // leaf's edge may read them.
            ClampCount inactive;
            for (size_t i = r.begin(); i != r.end(); ++i) {
                typename GridT::ValueType* v = leaves[i]->buffer().data();
                for (openvdb::Index n = 0; n < LeafT::SIZE; ++n)
                    if (!isClean(v[n]))
                        clampValue(v[n], leaves[i]->isValueOn(n) ? c : inactive, 1);
            }
            return c;
        },
        [](ClampCount a, const ClampCount& b) {
            a.add(b);
            return a;
        });
    // Active tiles above the leaf level: few, so serially.
    auto it = grid.tree().beginValueOn();
    it.setMaxDepth(decltype(it)::LEAF_DEPTH - 1);
    for (; it; ++it) {
        typename GridT::ValueType v = *it;
        if (clampValue(v, count, it.getVoxelCount()))
            it.setValue(v);
    }
    return count;
}

template ClampCount clampGrid(openvdb::FloatGrid& grid);
template ClampCount clampGrid(openvdb::Vec3SGrid& grid);

void ClampReport::add(const std::string& name, const ClampCount& c)
{
    if (c.total() == 0)
        return;
    for (auto& entry : mClamped)
        if (entry.first == name) {
            entry.second.add(c);
            return;
        }
    mClamped.push_back({name, c});
}

uint64_t ClampReport::warn(const std::string& volumeLabel) const
{
    if (mClamped.empty())
        return 0;
    ClampCount all;
    std::string names;
    for (const auto& [name, c] : mClamped) {
        all.add(c);
        names += (names.empty() ? "" : ", ") + name + (mClamped.size() > 1 ? ": " + std::to_string(c.total()) : "");
    }
    logWarning("volume '" + volumeLabel + "': clamped " + std::to_string(all.total()) + " voxel values (" +
               std::to_string(all.negative) + " negative, " + std::to_string(all.nan) + " NaN, " +
               std::to_string(all.infinite) + " infinite) to 0 [" + names + "]");
    return all.total();
}

}  // namespace nimbus
