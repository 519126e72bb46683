// PathtraceScene.h: a RenderContext flattened into the buffers the OpenCL path tracer reads
// (kernels/shared/ptscene.h), and the preprocessor defines that specialise its kernel.
//
// Every volume's density and emission BrickGrids go up unchanged: their tables, pools and slot
// majorants are concatenated into three buffers, and a descriptor per volume records the
// offsets, the world-to-index transform and the medium (DESIGN "reference path tracer").
#pragma once

#include "../../kernels/shared/light.h"
#include "../../kernels/shared/ptscene.h"
#include "../geometry/KernelBvh.h"
#include "../render/RenderContext.h"

#include <cstdint>
#include <string>
#include <vector>

namespace nimbus {

// The kernel keeps per-volume walk state in private memory; this many may overlap a ray.
constexpr int kMaxPathtraceVolumes = 8;

struct PathtraceScene {
    std::vector<NbVolumeDesc> volumes;
    std::vector<int32_t> tables;
    std::vector<float> pools;
    std::vector<float> majorants;
    std::vector<NbLight> lights;  // the lights that can reach a volume
    std::vector<int> lightEntry;  // for each, its index in RenderContext::lights (AOV)
    bool emission = false;        // some volume has an emission grid
    bool velocity = false;        // some volume moves over the shutter (velocity blur)
    bool twoLobe = false;         // some phase function has a second lobe
    bool chromatic = false;       // some medium's coefficients differ between channels
    bool pnanovdb = false;        // densities as NanoVDB grids (NB_GRID_PNANOVDB, nanogrid.h)
    uint32_t lightTypes = 0;      // bit NB_LIGHT_<TYPE> set for each type present
    bool equiangular = false;     // render.equiangular and a point or spot light: NB_EQUIANGULAR
    // Scene geometry (docs/geometry.md): the BVH the kernel traverses; empty without geometry.
    KernelBvh geometry;
    bool holdouts = false;       // some object is a holdout (camera rays trace the BVH)
    bool shadowCasters = false;  // some object is a shadow caster (paths and light samples do)
    // camera.holdout_depth: the image (INFINITY for none), its size and pixels per camera pixel.
    std::vector<float> holdoutDepth;
    int holdoutDepthWidth = 0, holdoutDepthHeight = 0;
    float holdoutDepthScale[2] = {1.0f, 1.0f};
    int envLight = -1;            // the light (in `lights`) with an environment map, or -1
    NbEnvMap envMap{};
    std::vector<float> envData;   // envmap.h's layout; empty without a map

    // "-D NB_NUM_VOLUMES=2 -D NB_HAS_LIGHT_DISTANT=1 ..." for buildProgram. A scene without
    // geometry or depth map compiles none of their code (NB_GEOM_*, NB_HOLDOUT_DEPTH 0).
    std::string defines(bool globalMajorant) const;
    // Bytes of the volume buffers the kernel reads (tables, pools, slot majorants, descriptors).
    size_t volumeBytes() const
    {
        return tables.size() * sizeof(int32_t) + pools.size() * sizeof(float) + majorants.size() * sizeof(float) +
               volumes.size() * sizeof(NbVolumeDesc);
    }
};

// Throws Error when the scene has more than kMaxPathtraceVolumes volumes. pnanovdbDensity: the
// densities go up as NanoVDB grids inside `pools` for the NB_GRID_PNANOVDB kernel variant
// (kernels/shared/nanogrid.h) instead of as brick tables and pools; the slot majorants are the same.
PathtraceScene buildPathtraceScene(const RenderContext& ctx, bool pnanovdbDensity = false);

}  // namespace nimbus
