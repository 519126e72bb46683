// ActiveResample.h: trilinear resampling of a grid onto another lattice that walks only where the
// grid's active values reach (resampleActiveRegion), for the role grids that VdbLoad brings onto
// the density grid's voxels.
//
// OpenVDB's resampler (tools/GridTransformer.h, RangeProcessor) maps each leaf node's whole 8^3
// box onto the output lattice and samples every output voxel in the mapped box. Where the output
// lattice is much finer than the input's, a leaf with a few active voxels walks far more than its
// values reach: a role grid's leaf with 7 active voxels of 0.1 m over a density lattice of 3.2e-5
// m along one axis walked 7.9e7 output voxels, of which the 7 voxels' box covers 5.0e6 (issue 18,
// the slow class of docs/robustness.md, session 26). Here the walk is, per leaf, the box of its
// active voxels, and per active tile its box, each one voxel wider on every side (the box
// sampler's support) and mapped onto the output lattice (where one box around a block of 4^3
// leaves walks no more than their boxes one by one, that box: dense grids overlap less).
//
// The result is every output voxel's trilinear sample, active where any of the 8 input voxels it
// reads is active (OpenVDB's BoxSampler::sample), with the input's inactive voxels holding the
// background (VdbLoad's dropInactiveNodes makes them so). An output voxel outside every walked box
// reads 8 inactive voxels only (an active voxel v is read by sample points within (v - 1, v + 1)
// on each axis), so it is the background, inactive. OpenVDB's resampler gives the same values
// where it walks, but its walk starts each leaf at its first voxel's centre: below an active
// voxel on a leaf's low face, with no leaf beneath, it leaves out the interpolation's ramp
// (v - 1, v) (one voxel upsampled 10x: 20 output voxels along each axis here, 11 there). And
// around an active tile OpenVDB's TileSampler takes the tile's value a voxel past the tile (it
// means to shrink the tile's box by the sampler's radius, but BBox::expand(-1) grows it), where
// the trilinear samples ramp down (tests/volume/test_active_resample.cpp). Each
// output voxel's sample point is computed from its own index (not accumulated along a row), so a
// voxel reached from two boxes gets the same value from either, and the result does not depend on
// the thread count.
//
// Where the output is more than twice as coarse as the input along an axis, OpenVDB resamples in
// halving stages (a mip chain that filters before it samples): downsamplesInStages says when, and
// the caller keeps OpenVDB's resampler there (a leaf maps onto few output voxels, so its walk
// wastes little).
#pragma once

#include "../core/StopFlag.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/GridTransformer.h>
#include <openvdb/tools/Interpolation.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <vector>

namespace nimbus {

// Where the box sampler reads the voxels of `box` (index space of `from`): the box one voxel wider
// on each side (voxel v is read at sample points within (v - 1, v + 1)), its 8 corners mapped
// onto `to`'s index space; the least and greatest coordinates along each axis. Every corner is
// mapped, so mirrored, rotated and skewed transforms count right. The walk below covers it, and
// VdbLoad's memory estimate counts the leaves it touches.
struct MappedSupport {
    openvdb::Vec3d lo, hi;
};
inline MappedSupport mapSupport(const openvdb::CoordBBox& box, const openvdb::math::Transform& from,
                                const openvdb::math::Transform& to)
{
    MappedSupport m{openvdb::Vec3d(std::numeric_limits<double>::infinity()),
                    openvdb::Vec3d(-std::numeric_limits<double>::infinity())};
    for (int corner = 0; corner < 8; ++corner) {
        const openvdb::Vec3d c(corner & 1 ? box.max().x() + 1.0 : box.min().x() - 1.0,
                               corner & 2 ? box.max().y() + 1.0 : box.min().y() - 1.0,
                               corner & 4 ? box.max().z() + 1.0 : box.min().z() - 1.0);
        const openvdb::Vec3d q = to.worldToIndex(from.indexToWorld(c));
        m.lo = openvdb::math::minComponent(m.lo, q);
        m.hi = openvdb::math::maxComponent(m.hi, q);
    }
    return m;
}

// True where OpenVDB's resampleToMatch<BoxSampler> from `in` onto `out`'s lattice would filter in
// halving stages: the index-to-index map decomposes into scale, rotation and translation (no
// shear) and some scale is below 1/2 (GridTransformer's constructor and init).
template <class GridT>
bool downsamplesInStages(const GridT& in, const GridT& out)
{
    const openvdb::Mat4R map = in.transform().baseMap()->getAffineMap()->getMat4() *
                               out.transform().baseMap()->getAffineMap()->getMat4().inverse();
    openvdb::Vec3R scale, rotate, translate;
    if (!openvdb::tools::local_util::decompose(map, scale, rotate, translate))
        return false;
    return std::fabs(scale.x()) < 0.5 || std::fabs(scale.y()) < 0.5 || std::fabs(scale.z()) < 0.5;
}

// Resamples `in` (linear transform, inactive voxels holding the background) into `out`'s tree,
// on `out`'s transform, with `out`'s background equal to `in`'s. Stops early (leaving `out`
// part-filled: the caller throws) when `stop` is raised; polled every output row of a box.
template <class GridT>
void resampleActiveRegion(const GridT& in, GridT& out, const StopFlag* stop)
{
    using TreeT = typename GridT::TreeType;
    using ValueT = typename GridT::ValueType;
    const openvdb::math::Transform& from = in.transform();
    const openvdb::math::Transform& to = out.transform();

    // The input boxes: the active voxels of each leaf, or of each block of 4^3 leaves where one
    // box around them all is no larger than theirs one by one (each one voxel wider, the walk's
    // overlap: a dense grid's leaves walked one by one overlap their neighbours' by (10/8)^3,
    // 1.95x, a block's box by (34/32)^3, 1.2x; scattered voxels keep their leaves' boxes); and
    // each active tile.
    std::vector<openvdb::CoordBBox> inputBoxes;
    {
        std::map<openvdb::Coord, std::vector<openvdb::CoordBBox>> blocks;  // by the block's origin
        for (auto leaf = in.tree().cbeginLeaf(); leaf; ++leaf) {
            openvdb::CoordBBox box;  // empty; evalActiveBoundingBox grows it by the active voxels
            leaf->evalActiveBoundingBox(box, true);
            if (!box.empty()) {
                const openvdb::Coord o = leaf->origin();
                blocks[openvdb::Coord(o.x() >> 5, o.y() >> 5, o.z() >> 5)].push_back(box);
            }
        }
        auto walked = [](openvdb::CoordBBox box) {
            box.expand(1);
            return double(box.dim().x()) * double(box.dim().y()) * double(box.dim().z());
        };
        for (const auto& [origin, boxes] : blocks) {
            openvdb::CoordBBox all;
            double apart = 0.0;
            for (const openvdb::CoordBBox& box : boxes) {
                all.expand(box);
                apart += walked(box);
            }
            if (walked(all) <= apart)
                inputBoxes.push_back(all);
            else
                inputBoxes.insert(inputBoxes.end(), boxes.begin(), boxes.end());
        }
    }
    {
        auto tile = in.tree().cbeginValueOn();
        tile.setMaxDepth(decltype(tile)::LEAF_DEPTH - 1);
        for (; tile; ++tile) {
            openvdb::CoordBBox box;
            tile.getBoundingBox(box);
            inputBoxes.push_back(box);
        }
    }

    // Each box's support mapped onto the output lattice (mapSupport); the enclosing output voxels,
    // cut into slabs along x of at most 2^16 voxels (work items for the threads, and a tile's box
    // spread over them).
    std::vector<openvdb::CoordBBox> work;
    for (const openvdb::CoordBBox& box : inputBoxes) {
        const auto [lo, hi] = mapSupport(box, from, to);
        const openvdb::Coord first(int(std::floor(lo.x())), int(std::floor(lo.y())), int(std::floor(lo.z())));
        const openvdb::Coord last(int(std::ceil(hi.x())), int(std::ceil(hi.y())), int(std::ceil(hi.z())));
        const double row = double(last.y() - first.y() + 1) * double(last.z() - first.z() + 1);
        const int slab = int(std::clamp(65536.0 / row, 1.0, 1e9));
        for (int x = first.x(); x <= last.x(); x += slab) {
            const int end = int(std::min<int64_t>(int64_t(x) + slab - 1, last.x()));
            work.emplace_back(openvdb::Coord(x, first.y(), first.z()), openvdb::Coord(end, last.y(), last.z()));
            if (end == last.x())
                break;
        }
    }

    // The output index -> input index map, affine (both transforms are linear): p = origin +
    // i * dx + j * dy + k * dz.
    const openvdb::Vec3d origin = from.worldToIndex(to.indexToWorld(openvdb::Vec3d(0.0)));
    const openvdb::Vec3d dx = from.worldToIndex(to.indexToWorld(openvdb::Vec3d(1, 0, 0))) - origin;
    const openvdb::Vec3d dy = from.worldToIndex(to.indexToWorld(openvdb::Vec3d(0, 1, 0))) - origin;
    const openvdb::Vec3d dz = from.worldToIndex(to.indexToWorld(openvdb::Vec3d(0, 0, 1))) - origin;

    const ValueT background = in.background();
    tbb::enumerable_thread_specific<TreeT> trees([&] { return TreeT(background); });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, work.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
        TreeT& local = trees.local();
        openvdb::tree::ValueAccessor<const TreeT> inAcc(in.tree());
        openvdb::tree::ValueAccessor<TreeT> outAcc(local);
        for (size_t w = r.begin(); w != r.end(); ++w) {
            const openvdb::CoordBBox& box = work[w];
            openvdb::Coord ijk;
            for (ijk.x() = box.min().x(); ijk.x() <= box.max().x(); ++ijk.x()) {
                for (ijk.y() = box.min().y(); ijk.y() <= box.max().y(); ++ijk.y()) {
                    if (stopRaised(stop))
                        return;
                    const openvdb::Vec3d row = origin + dx * double(ijk.x()) + dy * double(ijk.y());
                    for (ijk.z() = box.min().z(); ijk.z() <= box.max().z(); ++ijk.z()) {
                        ValueT value;
                        if (openvdb::tools::BoxSampler::sample(inAcc, row + dz * double(ijk.z()), value))
                            outAcc.setValueOn(ijk, value);
                    }
                }
            }
        }
    });
    // Merged in the threads' order: a voxel two threads wrote holds the same value in both.
    for (TreeT& local : trees)
        out.tree().merge(local, openvdb::MERGE_ACTIVE_STATES);
}

}  // namespace nimbus
