// ShadowMapCache.h: a sequence's deep shadow maps and sky grids kept between frames (issue 16,
// item 1; docs/sequences.md). A light's map and its bake on the voxels are reused when the light
// (in kernel form), the shadow-map settings and the volumes are unchanged; an environment light's
// sky grid (SkyLight) when the light, its map (path, turn, intensity, the file's size and
// modification time), the sky grid's settings and the volumes are unchanged; the volumes meaning the
// very objects a VolumeCache handed back (an entry holds them, so their addresses cannot be
// taken by new volumes while it lives). Scenes with geometry are never cached (a mesh file may
// change with the frame). RenderContext::buildShadowMaps takes from it; the renderer gives the
// frame's maps back after the march.
#pragma once

#include "DeepShadowMap.h"
#include "LightCache.h"
#include "SkyLight.h"

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
    // Moves light i's sky grid into ctx if an entry matches the grid settings; false otherwise.
    bool takeSky(RenderContext& ctx, size_t i, const SkyLight::Settings& settings);
    // Keeps ctx's maps and sky grids for the next frame (ctx's lights lose them), dropping the
    // previous frame's. settings: the sky grids' (RenderContext::skySettings).
    void keep(RenderContext& ctx, const SkyLight::Settings& settings);

    size_t reused = 0, built = 0;        // shadow maps, of the last frame
    size_t skyReused = 0, skyBuilt = 0;  // sky grids, of the last frame

private:
    struct Entry {
        std::vector<std::shared_ptr<VolumeData>> volumes;
        std::string key;
        DeepShadowMap map;
        LightCache cache;
    };
    struct SkyEntry {
        std::vector<std::shared_ptr<VolumeData>> volumes;
        std::string key;
        SkyLight sky;
    };
    static std::string keyOf(const RenderContext& ctx, size_t i);
    static std::string skyKeyOf(const RenderContext& ctx, size_t i, const SkyLight::Settings& settings);
    static bool sameVolumes(const RenderContext& ctx, const std::vector<std::shared_ptr<VolumeData>>& kept);
    // The kept entry of `list` (mEntries or mSkies) with `key` for ctx's volumes, or list.end().
    template <class List>
    static typename List::iterator find(List& list, const RenderContext& ctx, const std::string& key);
    std::vector<Entry> mEntries;
    std::vector<SkyEntry> mSkies;
};

}  // namespace nimbus
