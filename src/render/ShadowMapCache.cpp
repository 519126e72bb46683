#include "ShadowMapCache.h"

#include "RenderContext.h"

#include <cstring>
#include <filesystem>

namespace nimbus {

std::string ShadowMapCache::keyOf(const RenderContext& ctx, size_t i)
{
    const RenderSettings& r = ctx.scene->render;
    const float settings[4] = {float(r.shadowMapResolution), r.tolerance, r.shadowStep, r.step};
    std::string key(sizeof(NbLight) + sizeof settings, '\0');
    std::memcpy(&key[0], &ctx.lights[i].light, sizeof(NbLight));
    std::memcpy(&key[sizeof(NbLight)], settings, sizeof settings);
    return key;
}

std::string ShadowMapCache::skyKeyOf(const RenderContext& ctx, size_t i, const SkyLight::Settings& settings)
{
    std::string key = keyOf(ctx, i);
    const float grid[7] = {float(settings.order), float(settings.nodesAcross), settings.shadowStep,
                           float(settings.hasViewer), settings.viewer.x, settings.viewer.y, settings.viewer.z};
    key.append(reinterpret_cast<const char*>(grid), sizeof grid);
    const Light& l = ctx.scene->lights[i];
    if (!l.map.empty()) {
        // The map as a file: its path, turn and intensity, and its size and time, so that a map
        // rewritten between frames under the same name is read again (EnvironmentMap::load).
        std::error_code ec;
        const auto size = std::filesystem::file_size(l.map, ec);
        const auto time = std::filesystem::last_write_time(l.map, ec).time_since_epoch().count();
        const double fields[4] = {double(l.rotate), double(l.mapIntensity), double(size), double(time)};
        key.append(reinterpret_cast<const char*>(fields), sizeof fields);
        key += l.map;
    }
    return key;
}

bool ShadowMapCache::sameVolumes(const RenderContext& ctx, const std::vector<std::shared_ptr<VolumeData>>& kept)
{
    const auto& vols = ctx.volumes.volumes();
    if (vols.size() != kept.size())
        return false;
    for (size_t v = 0; v < vols.size(); ++v)
        if (vols[v] != kept[v])
            return false;
    return true;
}

template <class List>
typename List::iterator ShadowMapCache::find(List& list, const RenderContext& ctx, const std::string& key)
{
    for (auto it = list.begin(); it != list.end(); ++it)
        if (it->key == key && sameVolumes(ctx, it->volumes))
            return it;
    return list.end();
}

bool ShadowMapCache::take(RenderContext& ctx, size_t i)
{
    if (!ctx.scene->geometry.empty())
        return false;
    const auto it = find(mEntries, ctx, keyOf(ctx, i));
    if (it == mEntries.end()) {
        ++built;
        return false;
    }
    ctx.lights[i].shadowMap = std::move(it->map);
    ctx.lights[i].cache = std::move(it->cache);
    mEntries.erase(it);
    ++reused;
    return true;
}

bool ShadowMapCache::takeSky(RenderContext& ctx, size_t i, const SkyLight::Settings& settings)
{
    if (!ctx.scene->geometry.empty()) {
        ++skyBuilt;
        return false;
    }
    const auto it = find(mSkies, ctx, skyKeyOf(ctx, i, settings));
    if (it == mSkies.end()) {
        ++skyBuilt;
        return false;
    }
    ctx.lights[i].sky = std::move(it->sky);
    mSkies.erase(it);
    ++skyReused;
    return true;
}

void ShadowMapCache::keep(RenderContext& ctx, const SkyLight::Settings& settings)
{
    mEntries.clear();
    mSkies.clear();
    if (!ctx.scene->geometry.empty())
        return;
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        LightEntry& e = ctx.lights[i];
        if (!e.sky)
            continue;
        mSkies.push_back(SkyEntry{ctx.volumes.volumes(), skyKeyOf(ctx, i, settings), std::move(*e.sky)});
        e.sky.reset();
    }
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        LightEntry& e = ctx.lights[i];
        if (!e.shadowMap || !e.cache)
            continue;
        mEntries.push_back(Entry{ctx.volumes.volumes(), keyOf(ctx, i), std::move(*e.shadowMap), std::move(*e.cache)});
        e.shadowMap.reset();
        e.cache.reset();
    }
}

}  // namespace nimbus
