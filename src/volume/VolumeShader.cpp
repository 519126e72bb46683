// VolumeShader.cpp: finding, compiling (OpenVDB AX, LLVM JIT) and running volume shaders.
//
// AX executes over the active values of each grid the program writes, so the caller's grids
// decide where a shader runs: @density keeps the density topology, and v@emission is given the
// union of the density, temperature and flame topologies, where emission can be non-zero.
// AX keeps active tiles as tiles where the result is uniform and streams them to voxels where
// it is not (its active-tile streaming), so sparse inputs stay sparse.
#include "VolumeShader.h"
#include "InputFiles.h"

#include "../core/DataFiles.h"

#include "../core/Error.h"
#include "../core/Log.h"

#include <openvdb/openvdb.h>
#include <openvdb_ax/ax.h>
#include <openvdb_ax/compiler/AttributeRegistry.h>
#include <openvdb_ax/compiler/Compiler.h>
#include <openvdb_ax/compiler/CustomData.h>
#include <openvdb_ax/compiler/Logger.h>
#include <openvdb_ax/compiler/VolumeExecutable.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
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
                if (access.name() == "emission" && access.writes())
                    mImpl->writesEmission = true;
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
                                                     const std::string& where) const
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
        mImpl->executable->execute(grids);
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
