// ShadowMapCache.h: a sequence's deep shadow maps kept between frames (issue 16, item 1;
// docs/sequences.md). A light's map and its bake on the voxels are reused when the light (in
// kernel form), the shadow-map settings and the volumes are unchanged, the volumes meaning the
// very objects a VolumeCache handed back (an entry holds them, so their addresses cannot be
// taken by new volumes while it lives). Scenes with geometry are never cached (a mesh file may
// change with the frame). RenderContext::buildShadowMaps takes from it; the renderer gives the
// frame's maps back after the march.
#pragma once

#include "DeepShadowMap.h"
#include "LightCache.h"

#include <memory>
#include <string>
#include <vector>

namespace nimbus {

struct RenderContext;
struct VolumeData;

class ShadowMapCache {
public:
    // Moves light i's map and bake into ctx if an entry matches; false otherwise.
    bool take(RenderContext& ctx, size_t i);
    // Keeps ctx's maps for the next frame (ctx's lights lose them), dropping the previous frame's.
    void keep(RenderContext& ctx);

    size_t reused = 0, built = 0;  // of the last frame

private:
    struct Entry {
        std::vector<std::shared_ptr<VolumeData>> volumes;
        std::string key;
        DeepShadowMap map;
        LightCache cache;
    };
    static std::string keyOf(const RenderContext& ctx, size_t i);
    static bool sameVolumes(const RenderContext& ctx, const Entry& e);
    std::vector<Entry> mEntries;
};

}  // namespace nimbus
