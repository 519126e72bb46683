// VdbToBricks.cpp: toBricks (VdbToBricks.h).
#include "VdbToBricks.h"

#include "../core/Error.h"
#include "../core/FormatBytes.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <type_traits>
#include <vector>

namespace nimbus {

namespace {

using openvdb::Coord;
using openvdb::CoordBBox;

// The brick table's limit: beyond it the dense table would need more than ~1 GB (the pool's is
// kMaxBricks, VdbToBricks.h).
constexpr uint64_t kMaxTableSlots = uint64_t(1) << 27;

inline float channel(float v, int)
{
    return v;
}
inline float channel(const openvdb::Vec3s& v, int c)
{
    return v[c];
}
inline bool isZero(float v)
{
    return v == 0.0f;
}
inline bool isZero(const openvdb::Vec3s& v)
{
    return v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f;
}

inline int floorDiv8(int v)
{
    return v >> BrickGrid::kBrickLog2;
}  // arithmetic shift: floor

// The brick pool's bytes (bricks of kBrickValues values of `channels` floats) and its table's.
inline double poolBytes(double bricks, int channels, uint64_t slots)
{
    return bricks * double(BrickGrid::kBrickValues) * double(channels) * sizeof(float) + double(slots) * sizeof(int32_t);
}

}  // namespace

template <class GridT>
BrickGrid toBricks(const GridT& grid, int channels, const std::string& where, size_t limitBytes)
{
    using TreeT = typename GridT::TreeType;
    using LeafT = typename TreeT::LeafNodeType;
    using ValueT = typename GridT::ValueType;
    static_assert(LeafT::DIM == BrickGrid::kBrick, "bricks are aligned with VDB leaf nodes");
    const TreeT& tree = grid.tree();

    BrickGrid bricks;
    CoordBBox bbox;
    if (!tree.evalActiveVoxelBoundingBox(bbox)) {
        bricks.reset({0, 0, 0}, {0, 0, 0}, channels);
        bricks.pruneZeroBricks();
        return bricks;
    }
    // The -1 layer holds the aprons of the bricks at the low end.
    const Coord lo(floorDiv8(bbox.min().x()) - 1, floorDiv8(bbox.min().y()) - 1, floorDiv8(bbox.min().z()) - 1);
    const Coord hi(floorDiv8(bbox.max().x()), floorDiv8(bbox.max().y()), floorDiv8(bbox.max().z()));
    const Coord dims = hi - lo + Coord(1);
    const uint64_t slots = uint64_t(dims.x()) * uint64_t(dims.y()) * uint64_t(dims.z());
    if (slots > kMaxTableSlots)
        // (The voxel counts in 64 bits: dims * 8 passes INT_MAX for a region near the int limits,
        // UBSan in fuzz_nvdb.)
        throw InputError(where + ": the active region spans " + std::to_string(uint64_t(dims.x()) * 8) + " x " +
                         std::to_string(uint64_t(dims.y()) * 8) + " x " + std::to_string(uint64_t(dims.z()) * 8) +
                         " voxels, too large for nimbus's brick table");
    auto slotOf = [&](int bx, int by, int bz) {
        return (uint64_t(bz - lo.z()) * dims.y() + uint64_t(by - lo.y())) * dims.x() + uint64_t(bx - lo.x());
    };

    // Bricks under active leaves, in parallel, plus the -1 neighbours that hold their apron.
    std::vector<const LeafT*> leaves;
    tree.getNodes(leaves);
    // A floor on the pool, checked before the brick list is built and sorted: every non-empty
    // leaf is a brick, and every active tile of a non-zero value covers its own bricks (leaves and
    // tiles never overlap; the apron layer comes on top). A fuzzed density of active tiles over
    // 1.5 M bricks spent most of its second (5-10 s under ASan) listing and sorting 1.2 x 10^7
    // brick slots that the exact check below then refused (fuzz_nvdb, session 30).
    {
        double floorBricks = 0.0;
        for (const LeafT* leaf : leaves)
            floorBricks += leaf->isEmpty() ? 0.0 : 1.0;
        auto tile = tree.cbeginValueOn();
        tile.setMaxDepth(decltype(tile)::LEAF_DEPTH - 1);
        for (; tile; ++tile)
            if (!isZero(*tile))
                floorBricks += double(tile.getVoxelCount()) / double(LeafT::NUM_VOXELS);
        const double floorBytes = poolBytes(floorBricks, channels, slots);
        if (!(floorBytes <= double(limitBytes)))
            throw InputError(where + ": at least " + std::to_string(uint64_t(floorBricks)) +
                             " bricks of 8^3 voxels are active, " + formatBytes(size_t(std::min(floorBytes, 1.8e19))) +
                             " or more with their table, more than render.memory_limit (" + formatBytes(limitBytes) +
                             "); raise render.memory_limit");
    }
    tbb::enumerable_thread_specific<std::vector<uint64_t>> marked;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves.size()), [&](const tbb::blocked_range<size_t>& r) {
        auto& out = marked.local();
        for (size_t i = r.begin(); i != r.end(); ++i) {
            if (leaves[i]->isEmpty())
                continue;
            const Coord o = leaves[i]->origin();
            const int bx = floorDiv8(o.x()), by = floorDiv8(o.y()), bz = floorDiv8(o.z());
            for (int n = 0; n < 8; ++n)
                out.push_back(slotOf(bx - (n & 1), by - ((n >> 1) & 1), bz - (n >> 2)));
        }
    });
    std::vector<uint64_t> list;
    for (auto& part : marked)
        list.insert(list.end(), part.begin(), part.end());
    // Active tiles: every brick they cover, and the -1 layer. Tiles of 0 add nothing.
    auto tile = tree.cbeginValueOn();
    tile.setMaxDepth(decltype(tile)::LEAF_DEPTH - 1);
    for (; tile; ++tile) {
        if (isZero(*tile))
            continue;
        CoordBBox box;
        tile.getBoundingBox(box);
        const Coord b0(floorDiv8(box.min().x()) - 1, floorDiv8(box.min().y()) - 1, floorDiv8(box.min().z()) - 1);
        const Coord b1(floorDiv8(box.max().x()), floorDiv8(box.max().y()), floorDiv8(box.max().z()));
        const uint64_t n = uint64_t(b1.x() - b0.x() + 1) * (b1.y() - b0.y() + 1) * (b1.z() - b0.z() + 1);
        if (list.size() + n > 8 * kMaxBricks)
            throw InputError(where + ": more than " + std::to_string(kMaxBricks) +
                             " bricks of 8^3 voxels are active, too large to render");
        for (int z = b0.z(); z <= b1.z(); ++z)
            for (int y = b0.y(); y <= b1.y(); ++y)
                for (int x = b0.x(); x <= b1.x(); ++x)
                    list.push_back(slotOf(x, y, z));
    }
    tbb::parallel_sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    if (list.size() > kMaxBricks)
        throw InputError(where + ": " + std::to_string(list.size()) + " bricks of 8^3 voxels are active, more than " +
                         std::to_string(kMaxBricks));
    // The pool and the table, before either is allocated (a fuzzed file's density of active tiles
    // filled 4.9 GB of bricks under a 64 MiB render.memory_limit: fuzz_nvdb).
    const double bytes = poolBytes(double(list.size()), channels, slots);
    if (!(bytes <= double(limitBytes)))
        throw InputError(where + ": " + std::to_string(list.size()) + " bricks of 8^3 voxels are active, " +
                         formatBytes(size_t(std::min(bytes, 1.8e19))) + " with their table, more than " +
                         "render.memory_limit (" + formatBytes(limitBytes) + "); raise render.memory_limit");

    auto tableCoord = [&](uint64_t s) {
        return Coord(int(s % uint64_t(dims.x())), int((s / uint64_t(dims.x())) % uint64_t(dims.y())),
                     int(s / (uint64_t(dims.x()) * dims.y())));
    };
    auto brickOrigin = [&](uint64_t s) {
        const Coord t = tableCoord(s);
        return Coord((t.x() + lo.x()) * BrickGrid::kBrick, (t.y() + lo.y()) * BrickGrid::kBrick,
                     (t.z() + lo.z()) * BrickGrid::kBrick);
    };
    // A brick's core and apron (the faces at local index 8) come from the 8 leaf-sized blocks
    // at origin + 8 n, n in {0, 1}^3: from each, the active values of its leaf, or the one tile
    // (or background) that covers the whole block. One node lookup per block, not one accessor
    // probe per apron value. Block n supplies local x in [0, 8) where n.x = 0, else x = 8 only.
    // visit(x0, x1, y0, y1, z0, z1, leaf or nullptr, tile value): false stops.
    auto forEachBlock = [&](typename GridT::ConstAccessor& acc, const Coord& origin, auto&& visit) {
        constexpr int S = BrickGrid::kStored;
        for (int n = 0; n < 8; ++n) {
            const int dx = n & 1, dy = (n >> 1) & 1, dz = n >> 2;
            const Coord block = origin + Coord(dx * 8, dy * 8, dz * 8);
            const int x0 = dx * 8, x1 = dx ? S : 8, y0 = dy * 8, y1 = dy ? S : 8, z0 = dz * 8, z1 = dz ? S : 8;
            ValueT tile = openvdb::zeroVal<ValueT>();
            const LeafT* leaf = acc.probeConstLeaf(block);
            if (!leaf && !(acc.probeValue(block, tile) && !isZero(tile)))
                continue;  // inactive or zero: the brick keeps its zeros there
            if (!visit(x0, x1, y0, y1, z0, z1, leaf, tile))
                return;
        }
    };
    auto offsetIn = [](int x, int y, int z) { return openvdb::Index(((x & 7) << 6) | ((y & 7) << 3) | (z & 7)); };

    // Keep only the slots whose brick would hold a non-zero value (active blocks of zeros, and
    // the -1 neighbours of leaves whose low faces are zero, would be all zero: a quarter of the
    // candidates on a typical cloud), so that none is filled and then pruned.
    std::vector<char> nonZero(list.size(), 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, list.size(), 16), [&](const tbb::blocked_range<size_t>& r) {
        typename GridT::ConstAccessor acc = grid.getConstAccessor();
        for (size_t i = r.begin(); i != r.end(); ++i)
            forEachBlock(acc, brickOrigin(list[i]),
                         [&](int x0, int x1, int y0, int y1, int z0, int z1, const LeafT* leaf, const ValueT&) {
                             if (leaf) {
                                 const ValueT* data = leaf->buffer().data();
                                 const auto& mask = leaf->getValueMask();
                                 for (int z = z0; z < z1; ++z)
                                     for (int y = y0; y < y1; ++y)
                                         for (int x = x0; x < x1; ++x) {
                                             const openvdb::Index offset = offsetIn(x, y, z);
                                             if (mask.isOn(offset) && !isZero(data[offset])) {
                                                 nonZero[i] = 1;
                                                 return false;
                                             }
                                         }
                                 return true;
                             }
                             nonZero[i] = 1;  // a non-zero tile
                             return false;
                         });
    });
    size_t kept = 0;
    for (size_t i = 0; i < list.size(); ++i)
        if (nonZero[i])
            list[kept++] = list[i];
    list.resize(kept);

    // Brick i holds slot list[i]; its values are first written (and its pages first touched)
    // by the parallel fill, which writes all of them.
    bricks.reset({lo.x(), lo.y(), lo.z()}, {dims.x(), dims.y(), dims.z()}, channels);
    bricks.allocateUnfilledBricks(list);
    constexpr int S = BrickGrid::kStored;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, list.size(), 16), [&](const tbb::blocked_range<size_t>& r) {
        typename GridT::ConstAccessor acc = grid.getConstAccessor();
        for (size_t i = r.begin(); i != r.end(); ++i) {
            float* out = bricks.brickValues(i);
            std::fill(out, out + size_t(BrickGrid::kBrickValues) * channels, 0.0f);
            auto store = [&](int x, int y, int z, const ValueT& v) {
                float* dst = out + ((z * S + y) * S + x) * channels;
                for (int c = 0; c < channels; ++c)
                    dst[c] = channel(v, c);
            };
            forEachBlock(acc, brickOrigin(list[i]),
                         [&](int x0, int x1, int y0, int y1, int z0, int z1, const LeafT* leaf, const ValueT& tile) {
                             if (!leaf) {
                                 for (int z = z0; z < z1; ++z)
                                     for (int y = y0; y < y1; ++y)
                                         for (int x = x0; x < x1; ++x)
                                             store(x, y, z, tile);
                                 return true;
                             }
                             const ValueT* data = leaf->buffer().data();  // loaded: the file was read whole
                             const auto& mask = leaf->getValueMask();
                             if constexpr (std::is_same_v<ValueT, float>) {
                                 // A transpose (VDB leaves run z fastest, bricks x), every value
                                 // active (the common case) or masked without a branch.
                                 const bool full = mask.isOn();
                                 for (int z = z0; z < z1; ++z)
                                     for (int y = y0; y < y1; ++y) {
                                         float* row = out + (z * S + y) * S;
                                         const openvdb::Index column = offsetIn(0, y, z);
                                         for (int x = x0; x < x1; ++x) {
                                             const openvdb::Index offset = column + openvdb::Index((x & 7) << 6);
                                             row[x] = full || mask.isOn(offset) ? data[offset] : 0.0f;
                                         }
                                     }
                                 return true;
                             }
                             for (int z = z0; z < z1; ++z)
                                 for (int y = y0; y < y1; ++y)
                                     for (int x = x0; x < x1; ++x) {
                                         const openvdb::Index offset = offsetIn(x, y, z);
                                         if (mask.isOn(offset))
                                             store(x, y, z, data[offset]);
                                     }
                             return true;
                         });
        }
    });
    bricks.updateMajorants();  // and the active bounds
    return bricks;
}

template BrickGrid toBricks(const openvdb::FloatGrid& grid, int channels, const std::string& where,
                            size_t limitBytes);
template BrickGrid toBricks(const openvdb::Vec3SGrid& grid, int channels, const std::string& where,
                            size_t limitBytes);

}  // namespace nimbus
