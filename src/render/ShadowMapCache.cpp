#include "ShadowMapCache.h"

#include "RenderContext.h"

#include <cstring>

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

bool ShadowMapCache::sameVolumes(const RenderContext& ctx, const Entry& e)
{
    const auto& vols = ctx.volumes.volumes();
    if (vols.size() != e.volumes.size())
        return false;
    for (size_t v = 0; v < vols.size(); ++v)
        if (vols[v] != e.volumes[v])
            return false;
    return true;
}

bool ShadowMapCache::take(RenderContext& ctx, size_t i)
{
    if (!ctx.scene->geometry.empty())
        return false;
    const std::string key = keyOf(ctx, i);
    for (auto it = mEntries.begin(); it != mEntries.end(); ++it)
        if (it->key == key && sameVolumes(ctx, *it)) {
            ctx.lights[i].shadowMap = std::move(it->map);
            ctx.lights[i].cache = std::move(it->cache);
            mEntries.erase(it);
            ++reused;
            return true;
        }
    ++built;
    return false;
}

void ShadowMapCache::keep(RenderContext& ctx)
{
    mEntries.clear();
    if (!ctx.scene->geometry.empty())
        return;
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
