#include "LightCache.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace nimbus {

namespace {

constexpr int kB = BrickGrid::kBrick, kS = BrickGrid::kStored;

// Stores tau at lattice value n of a brick's values.
inline void store(float* values, int n, int channels, Rgb tau)
{
    if (channels == 1) {
        values[n] = tau.x;
    } else {
        values[3 * n] = tau.x, values[3 * n + 1] = tau.y, values[3 * n + 2] = tau.z;
    }
}

// Grey optical depth at (fx, fy) in texel units and depth zq (march steps where the map kept its
// samples, else metres), with a soft sun's penumbra filter (DeepShadowMap::penumbraTexels): the
// mean transmittance of the taps.
float greyTexelDepth(const DeepShadowMap& map, float fx, float fy, float zq, DeepShadowMap::Cursor& cursor)
{
    auto at = [&](float x, float y) {
        return map.hasMarchSamples() ? map.greyMarchedDepthTexel(x, y, zq)
                                     : map.greyOpticalDepthTexel(x, y, zq, cursor);
    };
    const float r = map.penumbraTexels(map.hasMarchSamples() ? zq * map.marchSampleStep() : zq);
    if (!(r >= DeepShadowMap::kPenumbraMinTexels))
        return at(fx, fy);
    float T = 0.0f;
    for (int k = 0; k < DeepShadowMap::kPenumbraTaps; ++k)
        T += std::exp(-at(fx + r * DeepShadowMap::kPenumbraTapX[k], fy + r * DeepShadowMap::kPenumbraTapY[k]));
    return -std::log(std::max(T / float(DeepShadowMap::kPenumbraTaps), 1e-30f));
}

// The optical depth at one point: from the march samples where the map kept them (grey,
// orthographic), else from the compressed functions; filtered over a soft sun's penumbra.
inline Rgb opticalDepth(const DeepShadowMap& map, float3 p, int channels, DeepShadowMap::Cursor& cursor)
{
    int face;
    float u, v, z;
    if (channels == 1 && map.hasMarchSamples() && map.project(p, face, u, v, z)) {
        const float res = float(map.resolution());
        return splat(greyTexelDepth(map, u * res - 0.5f, v * res - 0.5f, z / map.marchSampleStep(), cursor));
    }
    return map.opticalDepth(p, &cursor);
}

// The brick's own lattice points, [0, 8)^3 from its origin (the apron, at 8, belongs to the
// neighbours). An orthographic map is affine in the point, and so in the lattice indices:
// three projections give every point's (u, v, z) by stepping.
void bakeOwnPoints(const DeepShadowMap& map, const Transform& worldFromIndex, Int3 o, int channels, float* values,
                   DeepShadowMap::Cursor& cursor)
{
    auto index = [&](int x, int y, int z) { return make_float3(float(o.x + x), float(o.y + y), float(o.z + z)); };
    if (map.projection() == DeepShadowMap::Projection::Orthographic) {
        int face;
        float3 a, ax, ay, az;
        map.project(worldFromIndex.point(index(0, 0, 0)), face, a.x, a.y, a.z);
        map.project(worldFromIndex.point(index(1, 0, 0)), face, ax.x, ax.y, ax.z);
        map.project(worldFromIndex.point(index(0, 1, 0)), face, ay.x, ay.y, ay.z);
        map.project(worldFromIndex.point(index(0, 0, 1)), face, az.x, az.y, az.z);
        const float3 dx = ax - a, dy = ay - a, dz = az - a;
        if (channels == 1) {  // grey: in texel units (depth in march steps where kept), one channel
            const float res = float(map.resolution());
            const float3 scale = make_float3(res, res, map.hasMarchSamples() ? 1.0f / map.marchSampleStep() : 1.0f);
            const float3 a0 = a * scale - make_float3(0.5f, 0.5f, 0.0f);
            const float3 tx = dx * scale, ty = dy * scale, tz = dz * scale;
            for (int z = 0; z < kB; ++z)
                for (int y = 0; y < kB; ++y) {
                    const float3 row = a0 + ty * float(y) + tz * float(z);
                    float* out = values + (z * kS + y) * kS;
                    // The penumbra's radius grows with depth: where a row's deeper end is under the
                    // filter's threshold, the row takes the unfiltered lookups (eight at once).
                    const float zEnd = std::max(row.z, row.z + tx.z * float(kB - 1));
                    const float rEnd = map.penumbraTexels(map.hasMarchSamples() ? zEnd * map.marchSampleStep() : zEnd);
                    if (rEnd >= DeepShadowMap::kPenumbraMinTexels) {
                        for (int x = 0; x < kB; ++x) {
                            const float3 q = row + tx * float(x);
                            out[x] = greyTexelDepth(map, q.x, q.y, q.z, cursor);
                        }
                    } else if (map.hasMarchSamples()) {
                        map.greyMarchedDepthRow(row.x, row.y, row.z, tx.x, tx.y, tx.z, kB, out);
                    } else {
                        for (int x = 0; x < kB; ++x) {
                            const float3 q = row + tx * float(x);
                            out[x] = map.greyOpticalDepthTexel(q.x, q.y, q.z, cursor);
                        }
                    }
                }
            return;
        }
        for (int z = 0; z < kB; ++z)
            for (int y = 0; y < kB; ++y) {
                const float3 row = a + dy * float(y) + dz * float(z);
                for (int x = 0; x < kB; ++x) {
                    const float3 q = row + dx * float(x);
                    store(values, (z * kS + y) * kS + x, channels,
                          map.filteredOpticalDepthAt(0, q.x, q.y, q.z, &cursor));
                }
            }
        return;
    }
    for (int z = 0; z < kB; ++z)
        for (int y = 0; y < kB; ++y)
            for (int x = 0; x < kB; ++x)
                store(values, (z * kS + y) * kS + x, channels,
                      map.opticalDepth(worldFromIndex.point(index(x, y, z)), &cursor));
}

}  // namespace

LightCache LightCache::bake(const DeepShadowMap& map, const VolumeSet& volumes, const StopFlag* stop)
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
        BrickGrid g = v->density.sameTopologyUnfilled(channels);  // both passes write every value
        const Transform& worldFromIndex = v->worldFromIndex;
        // Pass 1: every brick's own points. Pass 2: the apron (x, y or z = 8) is the next
        // brick's own point where that brick is allocated, copied; else looked up here.
        tbb::parallel_for(tbb::blocked_range<size_t>(0, g.brickCount(), 4), [&](const tbb::blocked_range<size_t>& r) {
            DeepShadowMap::Cursor cursor;
            for (size_t b = r.begin(); b != r.end(); ++b) {
                throwIfStopped(stop);
                bakeOwnPoints(map, worldFromIndex, g.brickOrigin(b), channels, g.brickValues(b), cursor);
            }
        });
        tbb::parallel_for(tbb::blocked_range<size_t>(0, g.brickCount(), 4), [&](const tbb::blocked_range<size_t>& r) {
            DeepShadowMap::Cursor cursor;
            for (size_t b = r.begin(); b != r.end(); ++b) {
                throwIfStopped(stop);
                float* values = g.brickValues(b);
                const Int3 o = g.brickOrigin(b);
                // The apron by neighbour: n = (dx, dy, dz) != 0 supplies local x = 8 where
                // dx = 1, else x in [0, 8) (likewise y, z): one table lookup per neighbour.
                for (int n = 1; n < 8; ++n) {
                    const int dx = n & 1, dy = (n >> 1) & 1, dz = n >> 2;
                    const int x0 = dx * kB, x1 = dx ? kS : kB, y0 = dy * kB, y1 = dy ? kS : kB, z0 = dz * kB,
                              z1 = dz ? kS : kB;
                    const int nb = g.allocatedBrick((o.x >> 3) + dx, (o.y >> 3) + dy, (o.z >> 3) + dz);
                    const float* src = nb >= 0 ? g.brickValues(size_t(nb)) : nullptr;
                    for (int z = z0; z < z1; ++z)
                        for (int y = y0; y < y1; ++y)
                            for (int x = x0; x < x1; ++x) {
                                const int at = (z * kS + y) * kS + x;
                                if (src) {
                                    const int m = ((z & (kB - 1)) * kS + (y & (kB - 1))) * kS + (x & (kB - 1));
                                    std::copy(src + size_t(m) * channels, src + size_t(m + 1) * channels,
                                              values + size_t(at) * channels);
                                } else {
                                    const float3 p = worldFromIndex.point(
                                        make_float3(float(o.x + x), float(o.y + y), float(o.z + z)));
                                    store(values, at, channels, opticalDepth(map, p, channels, cursor));
                                }
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
