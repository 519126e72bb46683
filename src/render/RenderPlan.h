// RenderPlan.h: what a scene needs and what it can leave out, decided before any heavy work
// (DESIGN "leave out what a scene does not need"). Printed by `nimbus info` and --explain.
#pragma once

#include "../scene/Scene.h"

#include <string>
#include <vector>

namespace nimbus {

struct LightPlan {
    std::string name;       // AOV suffix
    std::string type;
    bool used = true;       // false: skipped, with `reason`
    bool shadowMap = false; // transmittance from a deep shadow map (delta lights)
    bool sampled = false;   // transmittance by shadow rays (area, sphere, environment, soft sun)
    std::string projection; // orthographic / perspective / cube
    int resolution = 0;
    std::string reason;
    // Filled after the build:
    size_t shadowMapBytes = 0;
    double shadowMapSeconds = 0;
};

struct VolumePlan {
    std::string name;
    std::vector<std::string> gridsRead;
    bool emission = false;
    size_t bricks = 0;
    size_t memoryBytes = 0;
    float voxelSize = 0;
    float maxOpticalDepthPerVoxel = 0;  // max sigma_t * voxel size over channels
    float opticalDepthAcross = 0;        // max sigma_t * (bounding-box diagonal), an upper bound
    size_t clampedVoxels = 0;
    std::string bounds;
};

struct RenderPlan {
    Method method = Method::Single;
    std::vector<LightPlan> lights;
    std::vector<VolumePlan> volumes;
    std::vector<std::string> notes;      // other omissions and decisions, one line each
    std::vector<std::pair<std::string, double>> stageSeconds;

    std::string describe() const;  // multi-line, human readable
};

}  // namespace nimbus
