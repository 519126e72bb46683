#include "LightCache.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>

namespace nimbus {

LightCache LightCache::bake(const DeepShadowMap& map, const VolumeSet& volumes)
{
    auto start = std::chrono::steady_clock::now();
    LightCache cache;
    bool grey = true;
    for (auto& v : volumes.volumes()) {
        Rgb s = v->sigmaT();
        grey = grey && s.x == s.y && s.y == s.z;
    }
    const int channels = grey ? 1 : 3;
    for (auto& v : volumes.volumes()) {
        BrickGrid g = v->density.sameTopology(channels);
        const Transform& worldFromIndex = v->worldFromIndex;
        tbb::parallel_for(tbb::blocked_range<size_t>(0, g.brickCount(), 4), [&](const tbb::blocked_range<size_t>& r) {
            DeepShadowMap::Cursor cursor;
            for (size_t b = r.begin(); b != r.end(); ++b) {
                float* values = g.brickValues(b);
                Int3 o = g.brickOrigin(b);
                int n = 0;
                for (int z = 0; z < BrickGrid::kStored; ++z)
                    for (int y = 0; y < BrickGrid::kStored; ++y)
                        for (int x = 0; x < BrickGrid::kStored; ++x, ++n) {
                            float3 p = worldFromIndex.point(make_float3(float(o.x + x), float(o.y + y), float(o.z + z)));
                            Rgb t = map.opticalDepth(p, &cursor);
                            if (channels == 1) {
                                values[n] = t.x;
                            } else {
                                values[3 * n] = t.x, values[3 * n + 1] = t.y, values[3 * n + 2] = t.z;
                            }
                        }
            }
        });
        cache.mGrids.push_back(std::move(g));
    }
    cache.mSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return cache;
}

size_t LightCache::memoryBytes() const
{
    size_t bytes = 0;
    for (auto& g : mGrids)
        bytes += g.pool().size() * sizeof(float);  // the table is the density grid's
    return bytes;
}

}  // namespace nimbus
