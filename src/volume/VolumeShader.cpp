// VolumeShader.cpp: finding, compiling (OpenVDB AX, LLVM JIT) and running volume shaders.
//
// AX executes over the active values of each grid the program writes, so the caller's grids
// decide where a shader runs: @density keeps the density topology, and v@emission is given the
// union of the density, temperature and flame topologies, where emission can be non-zero.
// AX keeps active tiles as tiles where the result is uniform and streams them to voxels where
// it is not (its active-tile streaming), so sparse inputs stay sparse.
// One AX execute cannot be interrupted, so a run goes chunk by chunk (runInChunks), polling the
// render's stop flag between chunks.
#include "VolumeShader.h"
#include "InputFiles.h"

#include "../core/DataFiles.h"

#include "../core/Error.h"
#include "../core/Log.h"
#include "../core/StopFlag.h"

#include <openvdb/openvdb.h>
#include <openvdb_ax/ax.h>
#include <openvdb_ax/compiler/AttributeRegistry.h>
#include <openvdb_ax/compiler/Compiler.h>
#include <openvdb_ax/compiler/CustomData.h>
#include <openvdb_ax/compiler/Logger.h>
#include <openvdb_ax/compiler/VolumeExecutable.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

// The role grids a shader may read, and their AX types; DESIGN "Units and conventions".
const char* const kFloatRoles[] = {"density", "temperature", "flame"};
const char* const kVectorRoles[] = {"Cd", "vel"};

std::string builtinShaderDir()
{
    return dataPath(DataFile::Shaders);
}

bool sameFile(const fs::path& a, const fs::path& b)
{
    std::error_code ec;
    return fs::equivalent(a, b, ec);
}

bool isRegularFile(const fs::path& p)
{
    std::error_code ec;
    return fs::is_regular_file(p, ec);
}

// ---- running in chunks --------------------------------------------------------------------
//
// AX runs its program at every active voxel and tile of each grid the program writes, and reads
// and writes every grid at that voxel only (AX has no neighbour access for volumes). So the
// written grids can be cut into disjoint regions and run region by region: the nodes of a chunk
// (leaves and active tiles, grouped by the 64^3-voxel block their origin lies in) move out of
// every written grid into grids of their own, AX runs on those beside the whole read-only grids,
// and the nodes move back. A chunk holds blocks of about `chunkVoxels` active voxels (a tile
// counts its voxels), so a cancel waits for one chunk: at the default shader's few million voxels
// a second on two cores, a fraction of a second.

constexpr int kChunkBlockLog2 = 6;  // 64^3 voxels

openvdb::Coord blockOf(const openvdb::Coord& origin)
{
    return openvdb::Coord(origin.x() >> kChunkBlockLog2, origin.y() >> kChunkBlockLog2, origin.z() >> kChunkBlockLog2);
}

// One written grid's nodes, by block: leaves (level 0) and active tiles (their level and value).
template <class GridT>
struct GridNodes {
    using ValueT = typename GridT::ValueType;
    struct Node {
        openvdb::Coord origin;
        openvdb::Index level;
        ValueT value;
    };
    typename GridT::Ptr grid;
    std::map<openvdb::Coord, std::vector<Node>> byBlock;

    explicit GridNodes(typename GridT::Ptr g, std::map<openvdb::Coord, double>& cost) : grid(std::move(g))
    {
        for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
            const openvdb::Coord block = blockOf(leaf->origin());
            byBlock[block].push_back({leaf->origin(), 0, ValueT()});
            cost[block] += double(leaf->onVoxelCount());
        }
        auto tile = grid->tree().cbeginValueOn();
        tile.setMaxDepth(decltype(tile)::LEAF_DEPTH - 1);
        for (; tile; ++tile) {
            openvdb::CoordBBox box;
            tile.getBoundingBox(box);
            const openvdb::Coord block = blockOf(box.min());
            byBlock[block].push_back({box.min(), openvdb::Index(tile.getLevel()), *tile});
            cost[block] += double(box.volume());
        }
    }

    // Moves the nodes of `blocks` out of the grid into a new grid of the same name, transform and
    // background, left as inactive background where they were.
    typename GridT::Ptr take(const std::vector<openvdb::Coord>& blocks)
    {
        using LeafT = typename GridT::TreeType::LeafNodeType;
        typename GridT::Ptr part = openvdb::gridPtrCast<GridT>(grid->copyGridWithNewTree());
        auto& from = grid->tree();
        auto& to = part->tree();
        const ValueT background = from.background();
        for (const openvdb::Coord& block : blocks) {
            auto it = byBlock.find(block);
            if (it == byBlock.end())
                continue;
            for (const Node& n : it->second) {
                if (n.level == 0) {
                    if (LeafT* leaf = from.template stealNode<LeafT>(n.origin, background, false))
                        to.addLeaf(leaf);
                } else {
                    to.addTile(n.level, n.origin, n.value, true);
                    from.addTile(n.level, n.origin, background, false);
                }
            }
        }
        return part;
    }

    // Moves a chunk's nodes back, as the shader left them.
    void giveBack(GridT& part) { grid->tree().merge(part.tree(), openvdb::MERGE_ACTIVE_STATES); }
};

// Runs `executable` over `grids` chunk by chunk (above); throws Cancelled between chunks once
// `stop` is raised.
void runInChunks(const openvdb::ax::VolumeExecutable& executable, openvdb::GridPtrVec& grids,
                 const std::vector<std::string>& written, const StopFlag* stop, double chunkVoxels)
{
    using openvdb::FloatGrid;
    using openvdb::Vec3SGrid;
    std::map<openvdb::Coord, double> cost;  // active voxels by block, over every written grid
    std::vector<std::pair<size_t, GridNodes<FloatGrid>>> floats;
    std::vector<std::pair<size_t, GridNodes<Vec3SGrid>>> vectors;
    for (size_t i = 0; i < grids.size(); ++i) {
        if (std::find(written.begin(), written.end(), grids[i]->getName()) == written.end())
            continue;
        if (auto f = openvdb::gridPtrCast<FloatGrid>(grids[i]))
            floats.emplace_back(i, GridNodes<FloatGrid>(f, cost));
        else if (auto v = openvdb::gridPtrCast<Vec3SGrid>(grids[i]))
            vectors.emplace_back(i, GridNodes<Vec3SGrid>(v, cost));
    }
    if (cost.size() <= 1 || (floats.empty() && vectors.empty())) {
        executable.execute(grids);
        return;
    }
    std::vector<std::vector<openvdb::Coord>> chunks(1);
    double filled = 0.0;
    for (const auto& [block, voxels] : cost) {
        if (filled > 0.0 && filled + voxels > chunkVoxels) {
            chunks.emplace_back();
            filled = 0.0;
        }
        chunks.back().push_back(block);
        filled += voxels;
    }
    for (const auto& blocks : chunks) {
        throwIfStopped(stop);
        openvdb::GridPtrVec part = grids;
        std::vector<FloatGrid::Ptr> floatParts;
        std::vector<Vec3SGrid::Ptr> vectorParts;
        for (auto& [i, nodes] : floats)
            part[i] = floatParts.emplace_back(nodes.take(blocks));
        for (auto& [i, nodes] : vectors)
            part[i] = vectorParts.emplace_back(nodes.take(blocks));
        executable.execute(part);
        for (size_t k = 0; k < floats.size(); ++k)
            floats[k].second.giveBack(*floatParts[k]);
        for (size_t k = 0; k < vectors.size(); ++k)
            vectors[k].second.giveBack(*vectorParts[k]);
    }
    throwIfStopped(stop);
}

}  // namespace

ShaderFile findShader(const std::string& shader, const std::string& sceneDir, const std::string& where)
{
    const std::string name = shader.empty() ? "default" : shader;
    const fs::path builtinDefault = fs::path(builtinShaderDir()) / "default.ax";
    // A relative name or path: beside the scene first (its directory, as for VDB files), then each
    // directory of $NIMBUS_SHADER_PATH, then the built-in shaders; a scene built in code (no
    // file) reads the working directory instead of its own. With or without ".ax".
    const fs::path p(name);
    std::vector<fs::path> dirs;
    if (p.is_relative()) {
        dirs.push_back(sceneDir.empty() ? fs::path(".") : fs::path(sceneDir));
        for (const std::string& dir : searchPathDirs("NIMBUS_SHADER_PATH"))
            dirs.push_back(dir);
        dirs.push_back(builtinShaderDir());
    } else {
        dirs.push_back(fs::path());
    }
    const bool hasSuffix = p.extension() == ".ax";
    std::vector<fs::path> candidates;
    for (const auto& dir : dirs) {
        candidates.push_back(dir / p);
        if (!hasSuffix)
            candidates.push_back(dir / (name + ".ax"));
    }
    for (const auto& c : candidates)
        if (isRegularFile(c))
            return {c.lexically_normal().string(), sameFile(c, builtinDefault)};
    if (name == "default" || name == "default.ax")
        return {"", true};
    std::string searched;
    for (const auto& c : candidates)
        searched += (searched.empty() ? "" : ", ") + c.lexically_normal().string();
    throw InputError(where + ": shader '" + shader + "' not found (searched: " + searched + ")");
}

struct VolumeShader::Impl {
    std::string path;
    openvdb::ax::VolumeExecutable::Ptr executable;
    openvdb::ax::CustomData::Ptr data;  // $has_<role>, read by the executable at run time
    bool writesEmission = false;
    std::vector<std::string> written;  // the grids the program writes (AX iterates over these)
    double compileSeconds = 0.0;
};

VolumeShader::VolumeShader(const std::string& path, const std::string& where) : mImpl(std::make_unique<Impl>())
{
    namespace ax = openvdb::ax;
    mImpl->path = path;
    std::ifstream in(path);
    std::stringstream code;
    code << in.rdbuf();
    if (!in)
        throw InputError(where + ": cannot read shader '" + path + "'");

    auto t0 = std::chrono::steady_clock::now();
    openvdb::initialize();
    ax::initialize();  // idempotent and thread-safe; LLVM stays up for the process
    std::vector<std::string> errors, warnings;
    ax::Logger logger([&](const std::string& m) { errors.push_back(m); },
                      [&](const std::string& m) { warnings.push_back(m); });
    logger.setNumberedOutput(false);
    logger.setErrorPrefix("");
    logger.setWarningPrefix("");

    mImpl->data = ax::CustomData::create();
    for (const char* role : kFloatRoles)
        mImpl->data->insertData(std::string("has_") + role, openvdb::FloatMetadata(0.0f).copy());
    for (const char* role : kVectorRoles)
        mImpl->data->insertData(std::string("has_") + role, openvdb::FloatMetadata(0.0f).copy());

    try {
        const std::string text = code.str();
        ax::ast::Tree::ConstPtr tree = ax::ast::parse(text.c_str(), logger);
        if (tree && !logger.hasError()) {
            mImpl->executable = ax::Compiler::create()->compile<ax::VolumeExecutable>(*tree, logger, mImpl->data);
            const ax::AttributeRegistry::Ptr registry = ax::AttributeRegistry::create(*tree);
            for (const auto& access : registry->data())
                if (access.writes()) {
                    mImpl->writesEmission |= access.name() == "emission";
                    if (std::find(mImpl->written.begin(), mImpl->written.end(), access.name()) == mImpl->written.end())
                        mImpl->written.push_back(access.name());
                }
        }
    } catch (const std::exception& e) {
        errors.push_back(e.what());
    }
    mImpl->compileSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (const auto& w : warnings)
        logWarning(where + ": '" + path + "': AX: " + w);
    if (!errors.empty() || !mImpl->executable) {
        std::string message;
        for (const auto& e : errors)
            message += (message.empty() ? "" : "; ") + e;
        for (char& c : message)
            if (c == '\n')
                c = ' ';
        throw InputError(where + ": AX error in '" + path + "': " + (message.empty() ? "compilation failed" : message));
    }
    // A read of a grid nobody supplied is a shader error, not a reason to invent one.
    mImpl->executable->setCreateMissing(false);
}

VolumeShader::~VolumeShader() = default;

const std::string& VolumeShader::path() const
{
    return mImpl->path;
}
bool VolumeShader::writesEmission() const
{
    return mImpl->writesEmission;
}
double VolumeShader::compileSeconds() const
{
    return mImpl->compileSeconds;
}

std::shared_ptr<openvdb::GridBase> VolumeShader::run(std::vector<std::shared_ptr<openvdb::GridBase>>& grids,
                                                     const std::string& where, const StopFlag* stop,
                                                     double chunkVoxels) const
{
    using openvdb::FloatGrid;
    using openvdb::Vec3SGrid;
    auto find = [&](const std::string& role) -> openvdb::GridBase::Ptr {
        for (auto& g : grids)
            if (g && g->getName() == role)
                return g;
        return nullptr;
    };
    FloatGrid::Ptr density = openvdb::gridPtrCast<FloatGrid>(find("density"));
    if (!density)
        throw Error(where + ": internal: the shader needs a float density grid");

    auto setHas = [&](const std::string& role, bool has) {
        mImpl->data->getOrInsertData<openvdb::FloatMetadata>("has_" + role)->value() = has ? 1.0f : 0.0f;
    };
    for (const char* role : kFloatRoles) {
        bool has = bool(find(role));
        setHas(role, has);
        if (!has) {
            FloatGrid::Ptr empty = FloatGrid::create(0.0f);
            empty->setName(role);
            empty->setTransform(density->transformPtr());
            grids.push_back(empty);
        }
    }
    for (const char* role : kVectorRoles) {
        bool has = bool(find(role));
        setHas(role, has);
        if (!has) {
            Vec3SGrid::Ptr empty = Vec3SGrid::create(openvdb::Vec3s(0.0f));
            empty->setName(role);
            empty->setTransform(density->transformPtr());
            grids.push_back(empty);
        }
    }

    Vec3SGrid::Ptr emission;
    if (mImpl->writesEmission) {
        emission = Vec3SGrid::create(openvdb::Vec3s(0.0f));
        emission->setName("emission");
        emission->setTransform(density->transformPtr());
        for (const char* role : kFloatRoles)
            if (FloatGrid::Ptr g = openvdb::gridPtrCast<FloatGrid>(find(role)))
                emission->tree().topologyUnion(g->tree());
        grids.push_back(emission);
    }

    try {
        runInChunks(*mImpl->executable, grids, mImpl->written, stop, chunkVoxels);
    } catch (const Cancelled&) {
        throw;
    } catch (const std::exception& e) {
        std::string message = e.what();
        for (char& c : message)
            if (c == '\n')
                c = ' ';
        throw InputError(where + ": AX error running '" + mImpl->path + "': " + message);
    }
    return emission;
}

}  // namespace nimbus
