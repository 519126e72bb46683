// VdbLoad.cpp: buildVolumes (VolumeData.h), from a scene's volume sources to the BrickGrids the
// integrators sample.
//
// Per volume: read the role grids from the VDB file (or run the generator, Procedural.h), clamp
// bad values, run the volume shader when the scene needs one (VolumeShader.h) and convert the
// density and emission grids to bricks. Placement, roles, clamping: docs/volumes.md. This file
// reads the files and puts the steps together; the clamping is in VoxelClamp.h, the conversion
// in VdbToBricks.h.
#include "InputFiles.h"
#include "VolumeData.h"

#include "../core/DataFiles.h"
#include "../core/Error.h"
#include "../core/FormatBytes.h"
#include "../core/Log.h"
#include "../core/MemoryLimit.h"
#include "../core/StopFlag.h"
#include "../scene/SceneJson.h"
#include "../scene/SceneValidate.h"
#include "ActiveResample.h"
#include "NanoVdbFileReader.h"
#include "PluginSource.h"
#include "Procedural.h"
#include "VdbFileReader.h"
#include "VdbToBricks.h"
#include "VolumeShader.h"
#include "VoxelClamp.h"

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>
#include <openvdb/tools/GridTransformer.h>
#include <openvdb/tools/Prune.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

using openvdb::FloatGrid;
using openvdb::GridBase;
using openvdb::Vec3SGrid;

// Message prefixes: "<scene file>: volumes[i]<sub>".
struct Where {
    std::string file;
    size_t index = 0;
    std::string key(const std::string& sub = "") const
    {
        return file + ": volumes[" + std::to_string(index) + "]" + sub;
    }
};

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
    std::vector<std::string> names;                            // file grid names, for gridsRead
};

// A file's transform that is singular, non-finite or otherwise unusable is bad input (exit 2):
// OpenVDB throws ArithmeticError only when the map is first inverted, deep inside the build,
// which used to surface as a render failure (issue 18, failure 8).
constexpr double kMinVoxelAxis = 1e-30, kMaxVoxelAxis = 1e30;  // m, as the procedural voxel_size's range

void checkGridTransform(const GridBase& grid, const std::string& what)
{
    try {
        const openvdb::Mat4d m = grid.transform().baseMap()->getAffineMap()->getMat4();
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c)
                if (!std::isfinite(m(r, c)))
                    throw InputError(what + " has a non-finite transform");
        if (!(std::fabs(m.getMat3().det()) > 0.0))
            throw InputError(what + " has a singular transform (a zero voxel size?)");
        // nimbus places voxels in float: each index axis's length in metres must be a normal
        // float with room for the products of a march (a fuzzed file had 3.1e175).
        for (int axis = 0; axis < 3; ++axis) {
            const openvdb::Vec3d row = m.getMat3().row(axis);  // OpenVDB's Mat4: rows are the index axes
            const double length = std::hypot(row.x(), row.y(), row.z());
            if (!(length >= kMinVoxelAxis && length <= kMaxVoxelAxis)) {
                char text[32];
                std::snprintf(text, sizeof text, "%g", length);
                throw InputError(what + " has a transform whose index axis " + std::to_string(axis) + " is " + text +
                                 " m long, outside [1e-30, 1e30] (damaged?)");
            }
        }
        // A file stores a map's inverse beside it (OpenVDB's ScaleMap and ScaleTranslateMap keep
        // their reciprocal scales), and worldToIndex uses that copy: a damaged one places the voxels
        // by one transform and looks them up by another (a fuzzed file's density had voxels of
        // 1.5e-6 m along x and an inverse of 0.1 m voxels; its role grid resampled into 17 GB).
        for (const openvdb::Vec3d p : {openvdb::Vec3d(0.0), openvdb::Vec3d(1, 0, 0), openvdb::Vec3d(0, 1, 0),
                                       openvdb::Vec3d(0, 0, 1), openvdb::Vec3d(37, -11, 5)}) {
            const openvdb::Vec3d back = grid.transform().worldToIndex(grid.transform().indexToWorld(p));
            if (!((back - p).length() <= 1e-6 * (1.0 + p.length())))
                throw InputError(what + " has a transform whose stored inverse does not invert it (damaged)");
        }
    } catch (const openvdb::Exception& e) {
        throw InputError(what + " has an invalid transform: " + e.what());
    }
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
// velocity: the medium asks for velocity blur, so the vel role is required whatever the shader.
RoleGrids readVdb(const VolumeSource& source, const std::string& path, bool allRoles, bool velocity,
                  const Where& where)
{
    const std::string fileKey = where.key(".source.file");
    std::error_code ec;
    if (!fs::exists(path, ec))
        throw InputError(fileKey + ": cannot open '" + path + "': no such file");
    // Read whole (the conversion reads every leaf, from many threads), through a stream that
    // bounds what a damaged file can make OpenVDB allocate (VdbFileReader.h). An .nvdb file is
    // read by NanoVDB and its grids converted to OpenVDB grids (NanoVdbFileReader.h); from there
    // on both take the same path.
    std::unique_ptr<VdbFileReader> file;
    std::unique_ptr<NanoVdbFileReader> nanoFile;
    std::vector<std::string> available;
    try {
        if (NanoVdbFileReader::isNanoVdbPath(path)) {
            nanoFile = std::make_unique<NanoVdbFileReader>(path);
            available = nanoFile->gridNames();
        } else {
            file = std::make_unique<VdbFileReader>(path);
            available = file->gridNames();
        }
    } catch (const std::exception& e) {
        throw InputError(fileKey + ": cannot open '" + path + "': " + e.what());
    }
    auto has = [&](const std::string& n) {
        return std::find(available.begin(), available.end(), n) != available.end();
    };
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
    if (velocity && !roles.count("vel"))
        roles["vel"] = "vel";

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
        if (it == roles.end() || (vector && !allRoles && !(role == "vel" && velocity)))
            continue;
        const std::string& name = it->second;
        const std::string key = keyOf(role);
        GridBase::Ptr raw;
        try {
            raw = nanoFile ? nanoFile->readGrid(name) : file->readGrid(name);
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
        checkGridTransform(*grid, key + ": grid '" + name + "' in '" + path + "'");
        grid->setName(role);  // the shader reads it as @<role>
        out.grids.push_back({role, grid});
        out.names.push_back(name);
    }
    return out;
}

// Brings a role grid onto the density grid's voxels (AX reads every grid at the same index
// coordinates). Trilinear (BoxSampler) resampling, as the renderer would interpolate it.
// nimbus reads a role grid's active values (inactive ones are the background, as in a fog volume),
// so first the nodes with no active value, the inactive tiles and the leaves' inactive voxels
// become background (dropInactiveNodes). The walk (resampleActiveRegion, ActiveResample.h) is then
// each leaf's active voxels and each active tile, mapped; OpenVDB's own resampler, which walks
// every leaf's whole 8^3 box, only where it downsamples in stages. Its work and memory are known
// before the walk, and bounded three times:
// - by what the bricks could ever hold: a role grid whose active values (tiles counted voxel by
//   voxel), or whose nodes (each leaf's whole 8^3 box, each tile: a bound of either walk) mapped onto the density's
//   voxels, exceed kMaxBricks bricks of 8^3 voxels is refused (a 20 KB file with one active tile
//   of 4096^3 voxels under a skewed transform resampled for hours; one active voxel of 0.1 m over
//   a density of 0.1 mm voxels walks its leaf's 8000^3 density voxels, hours, though its own value
//   covers 1000^3);
// - by render.memory_limit: the leaves the mapped box touches (a thin or slanted box fills few
//   of each leaf's voxels, so leaves, not voxels, are what it costs), each taken three and a half
//   times (the resampled leaves, a working copy: the shader's output or the velocities in index
//   space, and the bricks made from them, 729/512 of a leaf), may not exceed the limit (a 21 KB
//   file's 729 velocities under a density of 1.5e-6 m by 0.1 m voxels resampled into 663,561
//   leaves: 17 GB resident and 77 s before the render's own estimate refused it);
// - by the int coordinates the resampler computes in: the walked nodes, on the role grid's
//   lattice and mapped onto the density's, lie within +-2^30 (kMaxWalkedIndex) voxels (a fuzzed
//   file's temperature grid had no active value and one inactive leaf near the int limit; its
//   mapped corners, 1e10, overflowed the sampler's cast to int).
constexpr double kMaxResampledVoxels = double(kMaxBricks) * 512.0;
constexpr double kMaxWalkedIndex = double(1 << 30);

// Leaf and internal nodes with no active value become inactive background tiles, and so do the
// inactive tiles of another value: what remains is what the resampler need walk. The inactive
// voxels of the leaves left become the background too, so that the walk writes nothing where no
// active value reaches: the resampled leaves are those of the mapped active box, as estimated.
template <class TreeT>
void dropInactiveNodes(TreeT& tree)
{
    openvdb::tools::pruneInactive(tree);
    const typename TreeT::ValueType background = tree.background();
    auto tile = tree.beginValueOff();
    tile.setMaxDepth(decltype(tile)::LEAF_DEPTH - 1);
    for (; tile; ++tile)
        if (!openvdb::math::isExactlyEqual(*tile, background))
            tile.setValue(background);
    for (auto leaf = tree.beginLeaf(); leaf; ++leaf)
        for (auto voxel = leaf->beginValueOff(); voxel; ++voxel)
            voxel.setValue(background);
}

// OpenVDB's interrupter interface (util/NullInterrupter.h) over a render's StopFlag: the
// transformer polls it between slices of its walk.
struct StopInterrupter {
    const StopFlag* stop;
    void start(const char* = nullptr) {}
    void end() {}
    bool wasInterrupted(int = -1) const { return stopRaised(stop); }
};

// The voxels and the 8^3 leaves of `target`'s lattice that the box sampler's support around the
// voxels of `box` (index space of `from`) covers (mapSupport, ActiveResample.h), one target voxel
// more on each side for the rounding.
struct MappedBox {
    double voxels = 0.0, leaves = 0.0;
    double reach = 0.0;  // the largest |index| of the mapped box on target's lattice
};
MappedBox mapBox(const openvdb::CoordBBox& box, const openvdb::math::Transform& from,
                 const openvdb::math::Transform& target)
{
    MappedBox m;
    if (box.empty())
        return m;
    const double inf = std::numeric_limits<double>::infinity();
    const auto [lo, hi] = mapSupport(box, from, target);
    m.voxels = m.leaves = 1.0;
    for (int a = 0; a < 3; ++a) {
        if (!(std::isfinite(lo[a]) && std::isfinite(hi[a])))
            return MappedBox{inf, inf};
        const double first = std::floor(lo[a]) - 1.0, last = std::ceil(hi[a]) + 1.0;
        m.reach = std::max({m.reach, std::fabs(first), std::fabs(last)});
        m.voxels *= last - first + 1.0;
        m.leaves *= std::floor(last / 8.0) - std::floor(first / 8.0) + 1.0;
    }
    return m;
}

template <class GridT>
typename GridT::Ptr resampleTo(const typename GridT::Ptr& grid, const openvdb::math::Transform::Ptr& target,
                               const std::string& where, size_t limitBytes, const StopFlag* stop)
{
    if (grid->transform() == *target)
        return grid;
    dropInactiveNodes(grid->tree());
    typename GridT::Ptr out = GridT::create(grid->background());
    out->setTransform(target);
    out->setName(grid->getName());
    if (grid->tree().activeVoxelCount() == 0)
        return out;  // nothing to walk: the background everywhere
    openvdb::CoordBBox walked;
    grid->tree().evalLeafBoundingBox(walked);
    const double ownReach = std::max(double(std::max(walked.max().x(), std::max(walked.max().y(), walked.max().z()))),
                                     -double(std::min(walked.min().x(), std::min(walked.min().y(), walked.min().z()))));
    const MappedBox walk = mapBox(walked, grid->transform(), *target);
    const double mappedReach = walk.reach;
    if (!(ownReach <= kMaxWalkedIndex && mappedReach <= kMaxWalkedIndex)) {
        char what[256];
        std::snprintf(what, sizeof what,
                      ": its active values reach index %.3g on its own voxels and %.3g on the density grid's, "
                      "past the +-2^30 nimbus resamples in (damaged, or a transform far from the density's)",
                      ownReach, mappedReach);
        throw InputError(where + what);
    }
    // The walk's work is at most its leaves' whole 8^3 boxes and its tiles mapped (OpenVDB's walk,
    // where it downsamples; nimbus's covers only the active voxels' support within them); the
    // memory, below, is what the active values fill.
    const double active = double(grid->activeVoxelCount());
    const double worst = std::max(active, walk.voxels);
    if (!(worst <= kMaxResampledVoxels)) {
        char what[300];
        std::snprintf(what, sizeof what,
                      ": its active region (%.3g voxels; its leaves and tiles, as the resampler walks them, %.3g on "
                      "the density grid's voxels) is more than the %.0f voxels nimbus resamples onto the density "
                      "grid (damaged, or a transform far from the density's)",
                      active, walk.voxels, kMaxResampledVoxels);
        throw InputError(where + what);
    }
    const MappedBox mapped = mapBox(grid->evalActiveVoxelBoundingBox(), grid->transform(), *target);
    const double bytes = mapped.leaves * 512.0 * double(sizeof(typename GridT::ValueType)) * (2.0 + 729.0 / 512.0);
    if (!(bytes <= double(limitBytes))) {
        char what[400];
        std::snprintf(what, sizeof what,
                      ": resampling it onto the density grid's voxels would take about %s (%.3g leaves of 8^3 "
                      "voxels, their bricks and a working copy), more than render.memory_limit (%s); raise "
                      "render.memory_limit, or give the grid the density's transform",
                      formatBytes(size_t(std::min(bytes, 1.8e19))).c_str(), mapped.leaves,
                      formatBytes(limitBytes).c_str());
        throw InputError(where + what);
    }
    if (downsamplesInStages(*grid, *out)) {
        StopInterrupter interrupter{stop};
        openvdb::tools::resampleToMatch<openvdb::tools::BoxSampler>(*grid, *out, interrupter);
    } else {
        resampleActiveRegion(*grid, *out, stop);  // the active region only
    }
    throwIfStopped(stop);  // an interrupted walk leaves `out` part-filled
    return out;
}

// ---- velocity ----------------------------------------------------------------------------------

// NaN and infinite velocities become 0 (counted in the volume's one warning); negative ones are
// kept, unlike the fog grids' values.
ClampCount clampVelocity(Vec3SGrid& grid)
{
    ClampCount c;
    for (auto it = grid.beginValueOn(); it; ++it) {
        const openvdb::Vec3s v = *it;
        bool nan = false, inf = false;
        for (int i = 0; i < 3; ++i)
            nan |= std::isnan(v[i]), inf |= std::isinf(v[i]);
        if (nan || inf) {
            (nan ? c.nan : c.infinite) += 1;
            it.setValue(openvdb::Vec3s(0.0f));
        }
    }
    return c;
}

// VolumeData::velocity from the vel grid (already on the density's voxels): the file's world
// units per second are the grid's world space, which the volume's transform then places, so in
// the density's index space a velocity is indexFromFile's linear part times v (the volume's
// transform cancels: it moves the grid and its velocities alike).
void buildVelocity(VolumeData& data, const Vec3SGrid& vel, const Transform& fileFromIndex, float scale,
                   const std::string& key, size_t limitBytes)
{
    const Transform indexFromFile = fileFromIndex.inverse();
    Vec3SGrid::Ptr index = vel.deepCopy();
    float maxSpeed = 0.0f;
    for (auto it = index->beginValueOn(); it; ++it) {
        const openvdb::Vec3s v = *it;
        const float3 vi = indexFromFile.vector(make_float3(v[0], v[1], v[2])) * scale;
        maxSpeed = std::max(maxSpeed, length(vi));
        it.setValue(openvdb::Vec3s(vi.x, vi.y, vi.z));
    }
    if (!std::isfinite(maxSpeed))
        throw InputError(key + ": velocities times velocity_scale overflow float");
    data.velocity = toBricks(*index, 3, key, limitBytes);
    data.maxSpeed = maxSpeed;
}

// ---- one volume --------------------------------------------------------------------------------

// " <size> <mtime ns>" of a file, "" where it cannot be read: part of a cache key, so that a file
// rewritten between two frames is read again.
std::string fileStamp(const std::string& path)
{
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    if (ec)
        return "";
    const auto time = fs::last_write_time(path, ec);
    if (ec)
        return "";
    return " " + std::to_string(size) + " " + std::to_string(time.time_since_epoch().count());
}

// Everything buildVolume reads for volume i, as one string (VolumeCache); "" for a source that
// is never kept (a plugin).
std::string volumeKey(const Scene& scene, size_t index, const std::string& sceneDir)
{
    const Volume& volume = scene.volumes[index];
    if (volume.source.type == SourceType::Plugin)
        return "";
    Scene one;
    one.volumes = {volume};
    std::string key = sceneToJson(one)["volumes"][0].dump() + "\ndir " + sceneDir;
    std::string vdbPath;
    if (volume.source.type == SourceType::Vdb) {
        const std::string path = resolveVdbPath(volume.source.file, sceneDir);
        vdbPath = path;
        key += "\nvdb " + path + fileStamp(path);
    }
    const std::string where = (scene.sourcePath.empty() ? "scene" : scene.sourcePath) + ": volumes[" +
                              std::to_string(index) + "].shader";
    const ShaderFile shader = findShader(volume.shader, sceneDir, where);
    key += "\nshader " + shader.path + fileStamp(shader.path);
    return key;
}

std::shared_ptr<VolumeData> buildVolume(const Scene& scene, size_t index, const std::string& sceneDir,
                                        std::map<std::string, std::shared_ptr<VolumeShader>>& shaders,
                                        const StopFlag* stop)
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
    const bool velocity = volume.medium.velocityScale != 0.0f;
    if (velocity && volume.source.type != SourceType::Vdb)
        throw InputError(where.key(".medium.velocity_scale") + ": velocity motion blur reads a `vel` grid, and a " +
                         (volume.source.type == SourceType::Procedural ? "procedural" : "plugin") +
                         " source has none; use a vdb source with a vel grid, or leave velocity_scale at 0");
    std::string vdbPath;
    if (volume.source.type == SourceType::Vdb) {
        const std::string path = resolveVdbPath(volume.source.file, sceneDir);
        vdbPath = path;
        RoleGrids read = readVdb(volume.source, path, !shaderFile.isDefault, velocity, where);
        for (auto& [role, grid] : read.grids)
            hasEmissionInputs |= role == "temperature" || role == "flame";
        grids = std::move(read.grids);
        data->gridsRead = std::move(read.names);
    } else if (volume.source.type == SourceType::Procedural) {
        grids.push_back({"density", makeProceduralGrid(volume.source, where.key(".source"), stop)});
        data->gridsRead.push_back("density (" + volume.source.generator + ")");
    } else {
        grids.push_back(
            {"density", makePluginGrid(volume.source, sceneDir, where.key(".source"), data->gridsRead, stop)});
    }

    throwIfStopped(stop);
    // Clamp what comes in (counting file voxels, before any resampling), so a shader never sees
    // NaN; then what the shader produced.
    ClampReport clamped;
    for (auto& [role, grid] : grids) {
        if (role == "vel")  // a velocity is signed: only NaN and inf are bad (clampVelocity)
            clamped.add(role, clampVelocity(*openvdb::gridPtrCast<Vec3SGrid>(grid)));
        else if (auto f = openvdb::gridPtrCast<FloatGrid>(grid))
            clamped.add(role, clampGrid(*f));
        else if (auto v = openvdb::gridPtrCast<Vec3SGrid>(grid))
            clamped.add(role, clampGrid(*v));
    }

    FloatGrid::Ptr density = openvdb::gridPtrCast<FloatGrid>(grids.front().second);
    const size_t limitBytes = memoryLimitBytes(double(scene.render.memoryLimit));
    for (size_t i = 1; i < grids.size(); ++i) {
        // Role grids other than the density come from a vdb source only.
        const std::string key = where.key(".source.grids." + grids[i].first) + ": grid '" +
                                grids[i].second->getName() + "' in '" + vdbPath + "'";
        try {
            if (auto f = openvdb::gridPtrCast<FloatGrid>(grids[i].second))
                grids[i].second = resampleTo<FloatGrid>(f, density->transformPtr(), key, limitBytes, stop);
            else if (auto v = openvdb::gridPtrCast<Vec3SGrid>(grids[i].second))
                grids[i].second = resampleTo<Vec3SGrid>(v, density->transformPtr(), key, limitBytes, stop);
        } catch (const openvdb::Exception& e) {  // OpenVDB's GridTransformer decomposes the pair's transforms
            throw InputError(key + ": cannot be resampled onto the density grid's voxels (" + e.what() + ")");
        }
    }

    throwIfStopped(stop);

    Vec3SGrid::Ptr emission;
    if (!shaderFile.isDefault || hasEmissionInputs) {
        if (shaderFile.path.empty())
            throw InputError(where.key(".shader") + ": the default shader 'default.ax' is not installed in " +
                             dataPath(DataFile::Shaders) + "; set NIMBUS_SHADER_PATH");
        // The run's worst case, checked before the shader is compiled and run (VolumeShader.cpp):
        // AX streams an active tile to voxels wherever its result is not uniform there, so every
        // active value of the grids it runs over, tiles counted voxel by voxel, may become a voxel
        // of the density (4 bytes) and of the emission (12). A fuzzed file's density of 365 active tiles with
        // value 0 (7.7e8 voxels) ran the default shader for 40 s to a 1.8 GB peak under a 64 MiB
        // render.memory_limit (fuzz_nvdb; the same grids as a .vdb alike).
        double shaded = 0.0;
        for (auto& [role, grid] : grids)
            if (role != "vel")
                shaded += double(grid->activeVoxelCount());
        const double shaderBytes = shaded * double(sizeof(float) + sizeof(openvdb::Vec3s));
        if (!(shaderBytes <= double(limitBytes))) {
            char what[400];
            std::snprintf(what, sizeof what,
                          " would run over %.3g active voxels (tiles counted voxel by voxel), up to %s of density "
                          "and emission voxels, more than render.memory_limit (%s); raise render.memory_limit, or "
                          "give the grids fewer active voxels",
                          shaded, formatBytes(size_t(std::min(shaderBytes, 1.8e19))).c_str(),
                          formatBytes(limitBytes).c_str());
            const std::string grids = vdbPath.empty() ? "" : " on the grids of '" + vdbPath + "'";
            throw InputError((shaderFile.isDefault ? where.key(".source") + ": the default (emission) shader"
                                                   : where.key(".shader") + ": the shader") +
                             grids + what);
        }
        // Compiled after that check: a run refused for its size costs no compile (~0.2 s here).
        auto& shader = shaders[shaderFile.path + fileStamp(shaderFile.path)];
        if (!shader) {
            shader = std::make_shared<VolumeShader>(shaderFile.path, where.key(".shader"));
            logInfo("shader '" + shaderFile.path + "' compiled in " +
                    std::to_string(int(shader->compileSeconds() * 1000.0 + 0.5)) + " ms");
        }
        openvdb::GridPtrVec vec;
        for (auto& [role, grid] : grids)
            vec.push_back(grid);
        emission = openvdb::gridPtrCast<Vec3SGrid>(shader->run(vec, where.key(".shader"), stop));
        clamped.add("density", clampGrid(*density));
        if (emission)
            clamped.add("emission", clampGrid(*emission));
    }

    throwIfStopped(stop);
    data->clampedVoxels = clamped.warn(label);

    const std::string densityKey =
        volume.source.type == SourceType::Vdb
            ? where.key(".source.grids.density") + ": grid '" + density->getName() + "' in '" + vdbPath + "'"
            : where.key(".source");
    data->density = toBricks(*density, 1, densityKey, limitBytes);
    // Extinction overflow (docs/volumes.md, "Extinction range"): the densest voxel times the
    // medium's coefficients, which validateScene bounded at density 1.
    const double densest = double(data->density.maxValue());
    const double atOne = maxExtinctionAtDensityOne(volume.medium);
    if (!(densest * atOne <= kMaxExtinction)) {
        char what[320];
        std::snprintf(what, sizeof what,
                      ": the extinction reaches %g 1/m (voxel density up to %g times (sigma_s + sigma_a) * "
                      "density_scale = %g 1/m), beyond the %g 1/m nimbus renders in float; lower density_scale",
                      densest * atOne, densest, atOne, kMaxExtinction);
        throw InputError(where.key(".medium.density_scale") + what);
    }
    if (emission)
        data->emission = toBricks(*emission, 3, where.key(".shader"), limitBytes);
    throwIfStopped(stop);

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
    for (auto& [role, grid] : grids)
        if (role == "vel")
            buildVelocity(*data, *openvdb::gridPtrCast<Vec3SGrid>(grid), fromVdb(density->transform()),
                          volume.medium.velocityScale,
                          where.key(".source.grids.vel") + ": grid '" + grid->getName() + "' in '" + vdbPath + "'",
                          limitBytes);
    return data;
}

}  // namespace

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

std::vector<std::shared_ptr<VolumeData>> buildVolumes(const Scene& scene, VolumeCache* cache, const StopFlag* stop)
{
    openvdb::initialize();  // registers the grid types for file IO; idempotent, thread-safe
    const std::string sceneDir =
        scene.sourcePath.empty() ? std::string() : fs::path(scene.sourcePath).parent_path().string();
    std::map<std::string, std::shared_ptr<VolumeShader>> localShaders;  // one compile per file
    auto& shaders = cache ? cache->shaders : localShaders;
    std::map<std::string, std::shared_ptr<VolumeData>> kept;  // this scene's, for the next
    std::vector<std::shared_ptr<VolumeData>> volumes;
    size_t reused = 0;
    for (size_t i = 0; i < scene.volumes.size(); ++i) {
        try {
            const std::string key = cache ? volumeKey(scene, i, sceneDir) : std::string();
            if (!key.empty()) {
                std::shared_ptr<VolumeData> found;
                if (auto k = kept.find(key); k != kept.end())
                    found = k->second;
                else if (auto c = cache->volumes.find(key); c != cache->volumes.end())
                    found = c->second;
                if (found) {
                    volumes.push_back(found);
                    kept[key] = found;
                    ++reused;
                    continue;
                }
            }
            throwIfStopped(stop);
            volumes.push_back(buildVolume(scene, i, sceneDir, shaders, stop));
            if (!key.empty())
                kept[key] = volumes.back();
        } catch (const Error&) {
            throw;
        } catch (const Cancelled&) {
            throw;
        } catch (const std::bad_alloc&) {
            throw Error((scene.sourcePath.empty() ? "scene" : scene.sourcePath) + ": volumes[" + std::to_string(i) +
                        "]: out of memory while building the volume");
        } catch (const std::exception& e) {
            throw Error((scene.sourcePath.empty() ? "scene" : scene.sourcePath) + ": volumes[" + std::to_string(i) +
                        "]: " + e.what());
        }
    }
    if (cache) {
        cache->volumes = std::move(kept);
        cache->reused = reused;
        cache->built = volumes.size() - reused;
    }
    return volumes;
}

}  // namespace nimbus
