// VdbLoad.cpp: buildVolumes (VolumeData.h), from a scene's volume sources to the BrickGrids the
// integrators sample.
//
// Per volume: read the role grids from the VDB file (or run the generator, Procedural.h), clamp
// bad values, run the volume shader when the scene needs one (VolumeShader.h) and convert the
// density and emission grids to bricks. Placement, roles, clamping: docs/volumes.md.
//
// Conversion: a BrickGrid brick holds voxels [8b, 8b + 8] per axis, i.e. its own 8^3 cells and
// an apron of the next brick's first voxels, so that a trilinear lookup touches one brick. The
// bricks needed are those under active leaves and active tiles and, for the apron, their
// neighbours at -1; they are enumerated from the tree's nodes and tiles, never by scanning the
// bounding box. Every stored value is read through a ValueAccessor, which resolves tiles the
// same way as leaf voxels, so a grid stored as active tiles converts to exactly the same bricks
// as its voxelised copy. Inactive values count as 0, whatever the background.
#include "VolumeData.h"

#include "../core/Error.h"
#include "../core/Log.h"
#include "PluginSource.h"
#include "Procedural.h"
#include "VolumeShader.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/GridTransformer.h>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <type_traits>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;
using openvdb::GridBase;
using openvdb::Vec3SGrid;

// Brick-table and brick-pool limits: beyond them the dense table or the bricks alone would need
// more than ~1 GB and ~6 GB, which no scene on this class of machine can afford.
constexpr uint64_t kMaxTableSlots = uint64_t(1) << 27;
constexpr uint64_t kMaxBricks = uint64_t(1) << 21;

// Message prefixes: "<scene file>: volumes[i]<sub>".
struct Where {
    std::string file;
    size_t index = 0;
    std::string key(const std::string& sub = "") const
    {
        return file + ": volumes[" + std::to_string(index) + "]" + sub;
    }
};

// ---- clamping ----------------------------------------------------------------------------------

struct ClampCount {
    uint64_t negative = 0, nan = 0, infinite = 0;
    uint64_t total() const { return negative + nan + infinite; }
    void add(const ClampCount& o)
    {
        negative += o.negative;
        nan += o.nan;
        infinite += o.infinite;
    }
};

// Sets a bad value to 0 and counts it `weight` times (the voxels a tile stands for); true if
// the value changed.
// Non-negative and finite: what a fog volume's values may be.
inline bool isClean(float v) { return v >= 0.0f && v <= std::numeric_limits<float>::max(); }
inline bool isClean(const openvdb::Vec3s& v) { return isClean(v[0]) && isClean(v[1]) && isClean(v[2]); }

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

// Clamps the active values of a fog volume to [0, inf): negative, NaN and infinite values
// become 0 (DESIGN "Coefficients": negative density is a user error to warn about, not a crash).
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

// ---- conversion to bricks ----------------------------------------------------------------------

inline float channel(float v, int) { return v; }
inline float channel(const openvdb::Vec3s& v, int c) { return v[c]; }
inline bool isZero(float v) { return v == 0.0f; }
inline bool isZero(const openvdb::Vec3s& v) { return v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f; }

inline int floorDiv8(int v) { return v >> BrickGrid::kBrickLog2; }  // arithmetic shift: floor

template <class GridT>
BrickGrid toBricks(const GridT& grid, int channels, const std::string& where)
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
        throw InputError(where + ": the active region spans " + std::to_string(dims.x() * 8) + " x " +
                         std::to_string(dims.y() * 8) + " x " + std::to_string(dims.z() * 8) +
                         " voxels, too large for nimbus's brick table");
    auto slotOf = [&](int bx, int by, int bz) {
        return (uint64_t(bz - lo.z()) * dims.y() + uint64_t(by - lo.y())) * dims.x() + uint64_t(bx - lo.x());
    };

    // Bricks under active leaves, in parallel, plus the -1 neighbours that hold their apron.
    std::vector<const LeafT*> leaves;
    tree.getNodes(leaves);
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

// ---- placement ---------------------------------------------------------------------------------

// OpenVDB's matrices act on row vectors (p' = p M, translation in row 3); nimbus's on columns.
Transform fromVdb(const openvdb::math::Transform& xform)
{
    const openvdb::Mat4d m = xform.baseMap()->getAffineMap()->getMat4();
    std::array<double, 16> r{};
    for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 4; ++col)
            r[row * 4 + col] = m(col, row);
    r[15] = 1.0;
    return Transform::fromRowMajor(r);
}

// ---- reading files -----------------------------------------------------------------------------

// The grids of a VDB file for one volume, by role.
struct RoleGrids {
    std::vector<std::pair<std::string, GridBase::Ptr>> grids;  // role -> grid, density first
    std::vector<std::string> names;                             // file grid names, for gridsRead
};

// Relative paths are relative to the scene file. The JSON loader has usually resolved them
// already (then relative to the working directory), so a path that exists as given is kept.
std::string resolveVdbPath(const std::string& file, const std::string& sceneDir)
{
    fs::path p(file);
    if (p.is_absolute() || sceneDir.empty())
        return p.lexically_normal().string();
    fs::path joined = (fs::path(sceneDir) / p).lexically_normal();
    std::error_code ec;
    if (fs::exists(joined, ec))
        return joined.string();
    fs::path rel = p.lexically_normal().lexically_relative(sceneDir);
    if (fs::exists(p, ec) || (!rel.empty() && *rel.begin() != ".."))
        return p.lexically_normal().string();
    return joined.string();
}

FloatGrid::Ptr asFloatGrid(const GridBase::Ptr& grid)
{
    if (auto f = openvdb::gridPtrCast<FloatGrid>(grid))
        return f;
    if (auto d = openvdb::gridPtrCast<openvdb::DoubleGrid>(grid)) {
        FloatGrid::Ptr f = FloatGrid::create(std::make_shared<openvdb::FloatTree>(d->tree()));
        f->setTransform(d->transform().copy());
        f->setGridClass(d->getGridClass());
        return f;
    }
    return nullptr;
}

Vec3SGrid::Ptr asVectorGrid(const GridBase::Ptr& grid)
{
    if (auto v = openvdb::gridPtrCast<Vec3SGrid>(grid))
        return v;
    if (auto d = openvdb::gridPtrCast<openvdb::Vec3DGrid>(grid)) {
        Vec3SGrid::Ptr v = Vec3SGrid::create(std::make_shared<openvdb::Vec3STree>(d->tree()));
        v->setTransform(d->transform().copy());
        return v;
    }
    return nullptr;
}

// Opens the file and reads the role grids. Density is required; a role the scene names
// explicitly must exist; a default name that is absent is skipped. allRoles: also read Cd and
// vel (for a custom shader; the default shader reads density, temperature and flame only).
RoleGrids readVdb(const VolumeSource& source, const std::string& path, bool allRoles, const Where& where)
{
    const std::string fileKey = where.key(".source.file");
    std::error_code ec;
    if (!fs::exists(path, ec))
        throw InputError(fileKey + ": cannot open '" + path + "': no such file");
    openvdb::io::File file(path);
    std::vector<std::string> available;
    try {
        file.open(/*delayLoad=*/false);  // the conversion reads every leaf, from many threads
        for (auto it = file.beginName(); it != file.endName(); ++it)
            available.push_back(it.gridName());
    } catch (const std::exception& e) {
        throw InputError(fileKey + ": cannot open '" + path + "': " + e.what());
    }
    auto has = [&](const std::string& n) { return std::find(available.begin(), available.end(), n) != available.end(); };
    auto listed = [&]() {
        std::string s;
        for (const auto& n : available)
            s += (s.empty() ? "" : ", ") + n;
        return s.empty() ? std::string("none") : s;
    };

    // role -> grid name: the scene's, else the default name where the file has it (density's
    // default is required, so it is always there to be checked).
    std::map<std::string, std::string> roles;
    for (const auto& [role, name] : source.grids)
        roles[role == "heat" ? "flame" : role] = name;
    if (!roles.count("density"))
        roles["density"] = "density";
    if (!roles.count("temperature") && has("temperature"))
        roles["temperature"] = "temperature";
    if (!roles.count("flame") && (has("flame") || has("heat")))
        roles["flame"] = has("flame") ? "flame" : "heat";

    auto keyOf = [&](const std::string& role) {
        bool heat = role == "flame" && source.grids.count("heat") && !source.grids.count("flame");
        return where.key(".source.grids." + (heat ? std::string("heat") : role));
    };
    for (const auto& [role, name] : roles)
        if (!has(name))
            throw InputError(keyOf(role) + ": grid '" + name + "' not found in '" + path + "' (grids: " + listed() +
                             ")");

    RoleGrids out;
    for (const std::string role : {"density", "temperature", "flame", "Cd", "vel"}) {
        auto it = roles.find(role);
        bool vector = role == "Cd" || role == "vel";
        if (it == roles.end() || (vector && !allRoles))
            continue;
        const std::string& name = it->second;
        const std::string key = keyOf(role);
        GridBase::Ptr raw;
        try {
            raw = file.readGrid(name);
        } catch (const std::exception& e) {
            throw InputError(key + ": cannot read grid '" + name + "' from '" + path + "': " + e.what());
        }
        GridBase::Ptr grid;
        if (vector)
            grid = asVectorGrid(raw);
        else
            grid = asFloatGrid(raw);
        if (!grid)
            throw InputError(key + ": grid '" + name + "' in '" + path + "' has type " + raw->valueType() + "; " +
                             (vector ? "a vec3s" : "a float") + " grid is needed");
        if (role == "density" && grid->getGridClass() == openvdb::GRID_LEVEL_SET)
            throw InputError(key + ": grid '" + name + "' in '" + path +
                             "' is a level set (signed distance), not a density; convert it to a fog volume");
        if (!grid->transform().isLinear())
            throw InputError(key + ": grid '" + name + "' in '" + path +
                             "' has a non-linear (frustum) transform; only affine transforms are supported");
        grid->setName(role);  // the shader reads it as @<role>
        out.grids.push_back({role, grid});
        out.names.push_back(name);
    }
    file.close();
    return out;
}

// Brings a role grid onto the density grid's voxels (AX reads every grid at the same index
// coordinates). Trilinear (BoxSampler) resampling, as the renderer would interpolate it.
template <class GridT>
typename GridT::Ptr resampleTo(const typename GridT::Ptr& grid, const openvdb::math::Transform::Ptr& target)
{
    if (grid->transform() == *target)
        return grid;
    typename GridT::Ptr out = GridT::create(grid->background());
    out->setTransform(target);
    out->setName(grid->getName());
    openvdb::tools::resampleToMatch<openvdb::tools::BoxSampler>(*grid, *out);
    return out;
}

// ---- one volume --------------------------------------------------------------------------------

std::shared_ptr<VolumeData> buildVolume(const Scene& scene, size_t index, const std::string& sceneDir,
                                        std::map<std::string, std::unique_ptr<VolumeShader>>& shaders)
{
    const Volume& volume = scene.volumes[index];
    const Where where{scene.sourcePath.empty() ? "scene" : scene.sourcePath, index};
    const std::string label = volume.name.empty() ? "volumes[" + std::to_string(index) + "]" : volume.name;
    auto data = std::make_shared<VolumeData>();
    data->name = volume.name;
    data->medium = volume.medium;

    const ShaderFile shaderFile = findShader(volume.shader, sceneDir, where.key(".shader"));

    // Role grids: density first, then what the shader may read.
    std::vector<std::pair<std::string, GridBase::Ptr>> grids;
    bool hasEmissionInputs = false;
    if (volume.source.type == SourceType::Vdb) {
        const std::string path = resolveVdbPath(volume.source.file, sceneDir);
        RoleGrids read = readVdb(volume.source, path, !shaderFile.isDefault, where);
        for (auto& [role, grid] : read.grids)
            hasEmissionInputs |= role == "temperature" || role == "flame";
        grids = std::move(read.grids);
        data->gridsRead = std::move(read.names);
    } else if (volume.source.type == SourceType::Procedural) {
        grids.push_back({"density", makeProceduralGrid(volume.source, where.key(".source"))});
        data->gridsRead.push_back("density (" + volume.source.generator + ")");
    } else {
        grids.push_back({"density", makePluginGrid(volume.source, sceneDir, where.key(".source"), data->gridsRead)});
    }

    // Clamp what comes in (counting file voxels, before any resampling), so a shader never sees
    // NaN; then what the shader produced.
    std::vector<std::pair<std::string, ClampCount>> clamped;
    auto count = [&](const std::string& name, const ClampCount& c) {
        if (c.total() == 0)
            return;
        for (auto& entry : clamped)
            if (entry.first == name) {
                entry.second.add(c);
                return;
            }
        clamped.push_back({name, c});
    };
    for (auto& [role, grid] : grids) {
        if (auto f = openvdb::gridPtrCast<FloatGrid>(grid))
            count(role, clampGrid(*f));
        else if (auto v = openvdb::gridPtrCast<Vec3SGrid>(grid))
            count(role, clampGrid(*v));
    }

    FloatGrid::Ptr density = openvdb::gridPtrCast<FloatGrid>(grids.front().second);
    for (size_t i = 1; i < grids.size(); ++i) {
        if (auto f = openvdb::gridPtrCast<FloatGrid>(grids[i].second))
            grids[i].second = resampleTo<FloatGrid>(f, density->transformPtr());
        else if (auto v = openvdb::gridPtrCast<Vec3SGrid>(grids[i].second))
            grids[i].second = resampleTo<Vec3SGrid>(v, density->transformPtr());
    }

    Vec3SGrid::Ptr emission;
    if (!shaderFile.isDefault || hasEmissionInputs) {
        if (shaderFile.path.empty())
            throw InputError(where.key(".shader") + ": the default shader 'default.ax' is not installed in " +
                             NIMBUS_SOURCE_DIR "/shaders; set NIMBUS_SHADER_PATH");
        auto& shader = shaders[shaderFile.path];
        if (!shader) {
            shader = std::make_unique<VolumeShader>(shaderFile.path, where.key(".shader"));
            logInfo("shader '" + shaderFile.path + "' compiled in " +
                    std::to_string(int(shader->compileSeconds() * 1000.0 + 0.5)) + " ms");
        }
        openvdb::GridPtrVec vec;
        for (auto& [role, grid] : grids)
            vec.push_back(grid);
        emission = openvdb::gridPtrCast<Vec3SGrid>(shader->run(vec, where.key(".shader")));
        count("density", clampGrid(*density));
        if (emission)
            count("emission", clampGrid(*emission));
    }

    if (!clamped.empty()) {
        ClampCount all;
        std::string names;
        for (const auto& [name, c] : clamped) {
            all.add(c);
            names += (names.empty() ? "" : ", ") + name + (clamped.size() > 1 ? ": " + std::to_string(c.total()) : "");
        }
        data->clampedVoxels = all.total();
        logWarning("volume '" + label + "': clamped " + std::to_string(all.total()) + " voxel values (" +
                   std::to_string(all.negative) + " negative, " + std::to_string(all.nan) + " NaN, " +
                   std::to_string(all.infinite) + " infinite) to 0 [" + names + "]");
    }

    const std::string densityKey = volume.source.type == SourceType::Vdb ? where.key(".source.grids.density")
                                                                         : where.key(".source");
    data->density = toBricks(*density, 1, densityKey);
    if (emission)
        data->emission = toBricks(*emission, 3, where.key(".shader"));

    // Placement: the grid's own index-to-world, then the volume's transform.
    data->worldFromIndex = volume.transform * fromVdb(density->transform());
    try {
        data->indexFromWorld = data->worldFromIndex.inverse();
    } catch (const Error&) {
        throw InputError(where.key(".transform") + ": singular (a zero scale?): the volume cannot be placed");
    }
    data->voxelSize = std::min({length(data->worldFromIndex.vector(make_float3(1, 0, 0))),
                                length(data->worldFromIndex.vector(make_float3(0, 1, 0))),
                                length(data->worldFromIndex.vector(make_float3(0, 0, 1)))});
    Bbox active = data->density.activeIndexBounds();
    active.expand(data->emission.activeIndexBounds());
    data->worldBounds = data->worldFromIndex.box(active);
    return data;
}

}  // namespace

std::vector<std::shared_ptr<VolumeData>> buildVolumes(const Scene& scene)
{
    openvdb::initialize();  // registers the grid types for file IO; idempotent, thread-safe
    const std::string sceneDir =
        scene.sourcePath.empty() ? std::string() : fs::path(scene.sourcePath).parent_path().string();
    std::map<std::string, std::unique_ptr<VolumeShader>> shaders;  // one compile per file
    std::vector<std::shared_ptr<VolumeData>> volumes;
    for (size_t i = 0; i < scene.volumes.size(); ++i) {
        try {
            volumes.push_back(buildVolume(scene, i, sceneDir, shaders));
        } catch (const Error&) {
            throw;
        } catch (const std::bad_alloc&) {
            throw Error((scene.sourcePath.empty() ? "scene" : scene.sourcePath) + ": volumes[" + std::to_string(i) +
                        "]: out of memory while building the volume");
        } catch (const std::exception& e) {
            throw Error((scene.sourcePath.empty() ? "scene" : scene.sourcePath) + ": volumes[" + std::to_string(i) +
                        "]: " + e.what());
        }
    }
    return volumes;
}

}  // namespace nimbus
