// VolumeData.h: a scene volume resolved to sampled grids: what the integrators read.
#pragma once

#include "../scene/Scene.h"
#include "BrickGrid.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace nimbus {

struct VolumeData {
    std::string name;
    // Density after the shader (and clamping to [0, inf)); multiply by medium.densityScale and
    // sigma_s / sigma_a to get coefficients in 1/m.
    BrickGrid density;
    // Emitted radiance per metre, W/(m^3 sr) RGB (3 channels), times medium.emissionScale.
    // Empty when the volume has no emission grid: then emission code does not run.
    BrickGrid emission;
    // Velocity motion blur (docs/motion-blur.md): the `vel` grid on the density's index lattice,
    // in index voxels per second, medium.velocityScale folded in (3 channels). Empty unless the
    // medium asks for velocity blur; zero where the file's vel grid has no active voxels.
    BrickGrid velocity;
    float maxSpeed = 0.0f;  // the largest |velocity| over its voxels, index voxels per second
    Transform worldFromIndex;  // the volume's "transform" after the grid's index-to-world
    Transform indexFromWorld;
    Bbox worldBounds;        // bound of the active bricks in world space
    float voxelSize = 1.0f;  // smallest world-space voxel edge, metres
    Medium medium;
    std::vector<std::string> gridsRead;  // for the render plan
    size_t clampedVoxels = 0;            // negative / NaN / inf values clamped on load

    Rgb sigmaT() const { return (medium.sigma_s + medium.sigma_a) * medium.densityScale; }
    Rgb sigmaS() const { return medium.sigma_s * medium.densityScale; }
    bool hasEmission() const { return !emission.empty(); }
    bool hasVelocity() const { return !velocity.empty(); }
};

class StopFlag;
class VolumeShader;

// What a sequence keeps between frames (docs/sequences.md): the last frame's volumes, each
// under a key of everything its build reads (the volume's keys as JSON, the resolved VDB and
// shader paths with each file's size and modification time, the scene's directory), and the
// compiled shaders by path and stamp. A frame whose volume has the same key reuses the built
// VolumeData (immutable once built) instead of reading and converting the file again. Plugin
// sources are never kept: a plugin is code that may answer differently each call. Only the last
// frame's volumes are held, so a long sequence holds at most two frames' worth.
struct VolumeCache {
    std::map<std::string, std::shared_ptr<VolumeData>> volumes;
    std::map<std::string, std::shared_ptr<VolumeShader>> shaders;
    size_t reused = 0, built = 0;  // of the last buildVolumes call
};

// Builds every volume of the scene: loads VDB files or runs the procedural generators, runs the
// shader, clamps bad voxels (one warning per volume, with the count) and converts to bricks.
// Throws InputError naming the file and key path for missing files or grids. With a cache,
// volumes whose key the cache holds are reused, and the cache then holds this scene's volumes.
// A raised `stop` (the render's cancel, RenderControl.h) ends the load within a generator block,
// a resampling slice or a step of a volume's build, and throws Cancelled; the cache is unchanged.
// OpenVDB's file read and a shader's run are not interrupted (docs/robustness.md).
std::vector<std::shared_ptr<VolumeData>> buildVolumes(const Scene& scene, VolumeCache* cache = nullptr,
                                                      const StopFlag* stop = nullptr);

}  // namespace nimbus
