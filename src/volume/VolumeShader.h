// VolumeShader.h: volume shaders, OpenVDB AX snippets (shaders/*.ax) that map a volume's grids
// to the optical properties the renderer reads: @density and v@emission (W/(m^3 sr), RGB).
//
// Contract (docs/volumes.md): the shader sees the volume's grids under their role names
// (@density, @temperature, @flame, v@Cd, v@vel), all on the density grid's voxels; a role the
// volume lacks reads as 0 and $has_<role> tells which are real (1) or missing (0). It runs over
// the active voxels and tiles of each grid it writes; v@emission covers the union of the
// density, temperature and flame topologies.
//
// This header names no OpenVDB type beyond a forward declaration (see Procedural.h).
#pragma once

#include <openvdb/version.h>  // the versioned namespace only (macros, no OpenVDB types)

#include <memory>
#include <string>
#include <vector>

namespace openvdb {
OPENVDB_USE_VERSION_NAMESPACE
namespace OPENVDB_VERSION_NAME {
class GridBase;
}
}  // namespace openvdb

namespace nimbus {

class StopFlag;

// Where a volume's "shader" field points. A relative name or path (with or without ".ax") is
// looked for beside the scene (sceneDir; the working directory for a scene with no file), then
// in each directory of $NIMBUS_SHADER_PATH (':'-separated), then in the built-in shaders/
// (dataPath(DataFile::Shaders): the install's or the source tree's); an absolute path is taken
// as it is. The error lists every place it looked. "" means "default". isDefault: the file is
// the built-in shaders/default.ax, whose work nimbus does itself for density-only volumes; path
// is empty when the default was asked for and is not installed (fine until a volume needs
// emission).
struct ShaderFile {
    std::string path;
    bool isDefault = false;
};

// Throws InputError "<where>: shader 'x' not found (searched: ...)".
ShaderFile findShader(const std::string& shader, const std::string& sceneDir, const std::string& where);

class VolumeShader {
public:
    // Reads and compiles the AX file. Throws InputError "<where>: ..." when the file cannot be
    // read or AX reports errors (all of them, on one line); AX warnings go to logWarning.
    VolumeShader(const std::string& path, const std::string& where);
    ~VolumeShader();
    VolumeShader(const VolumeShader&) = delete;
    VolumeShader& operator=(const VolumeShader&) = delete;

    // Runs the shader. grids: the volume's role grids named after their roles, FloatGrid for
    // density, temperature and flame, Vec3SGrid for Cd and vel, on the density grid's transform;
    // missing roles are added as empty grids. Writes @density in place and returns the emission
    // grid (openvdb::Vec3SGrid, unclamped) or nullptr when the shader does not write v@emission.
    // Not thread-safe: one executable serves every volume, and $has_<role> is set per run.
    // The run goes chunk by chunk (runInChunks, VolumeShader.cpp), `stop` polled between chunks
    // of about `chunkVoxels` active voxels: a raised flag throws Cancelled within one chunk.
    std::shared_ptr<openvdb::GridBase> run(std::vector<std::shared_ptr<openvdb::GridBase>>& grids,
                                           const std::string& where, const StopFlag* stop = nullptr,
                                           double chunkVoxels = kShaderChunkVoxels) const;
    static constexpr double kShaderChunkVoxels = 1 << 20;

    const std::string& path() const;
    bool writesEmission() const;
    double compileSeconds() const;  // parse + JIT compile, wall clock

private:
    struct Impl;
    std::unique_ptr<Impl> mImpl;
};

}  // namespace nimbus
