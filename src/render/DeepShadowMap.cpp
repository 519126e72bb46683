// DeepShadowMap.cpp: building a deep shadow map (DeepShadowMap.h): per texel, march the light
// ray (one by one, or eight parallel rays at once, MarchParallelRays.h), compress it
// (ShadowMapCompression.cpp) and, where asked, keep the march samples for the bake; rows in
// parallel, then laid end to end. Where the texels look is in ShadowMapProjection.cpp, the
// lookups in ShadowMapLookup.cpp and ShadowMapMarchSamples.h.
#include "DeepShadowMap.h"

#include "../core/StepCount.h"

#include "BrickWalk.h"
#include "MarchParallelRays.h"

#include "../volume/OccupiedBricks.h"

#include "../core/Error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace nimbus {

DeepShadowMap DeepShadowMap::build(const NbLight& light, const VolumeSet& volumes, const Settings& settings)
{
    auto start = std::chrono::steady_clock::now();
    DeepShadowMap m;
    m.mRes = std::max(1, settings.resolution);
    m.mTolerance = settings.tolerance;
    m.mStepFraction = settings.stepFraction;
    m.mGrey = true;
    m.mStop = settings.stop;
    for (auto& v : volumes.volumes()) {
        const Rgb k = v->sigmaT();
        m.mGrey = m.mGrey && k.x == k.y && k.y == k.z;
    }
    const Bbox& bounds = volumes.worldBounds();
    m.placeFaces(light, volumes);
    if (m.mProjection == Projection::Orthographic && settings.penumbraSlope > 0.0f)
        m.mPenumbraTexelsPerMetre = 0.5f * settings.penumbraSlope * float(m.mRes) / m.mFaces[0].extent;

    const int res = m.mRes;
    const size_t texels = size_t(res) * res * m.mFaces.size();
    // Keep the march samples for the bake where the march runs on one uniform lattice per ray
    // (one grey volume, DeepShadowMap::marchRay's brick walk) and they fit the budget.
    const auto& vols = volumes.volumes();
    bool keep = false;
    BulkVector<TexelSamples> sampleIndex;        // per texel, while the rows are built
    std::vector<std::vector<float>> sampleRows;  // per row of texels: their samples
    if (settings.keepMarchSamples && m.mProjection == Projection::Orthographic && m.mGrey && vols.size() == 1 &&
        vols[0]->density.channels() == 1) {
        m.mSampleDz = settings.stepFraction * vols[0]->voxelSize;
        const float3 e = bounds.hi - bounds.lo;
        const double perTexel = double(length(e)) / double(m.mSampleDz) + 3.0;
        if (m.mSampleDz > 0.0f && double(texels) * perTexel * sizeof(float) <= double(kMarchSamplesBudget)) {
            keep = true;
            m.mInvSampleDz = 1.0f / m.mSampleDz;
            sampleIndex.resize(texels);
            sampleRows.resize(size_t(res));
            for (auto& row : sampleRows)  // address space only: pages arrive as rows fill
                row.reserve(size_t(double(res) * perTexel));
        }
    }
    const std::vector<char> texelMeetsBricks =
        m.mProjection == Projection::Orthographic ? m.texelsMeetingBricks(volumes) : std::vector<char>();
    const std::vector<float> stops =
        settings.shadowCasters ? m.texelStops(*settings.shadowCasters) : std::vector<float>();
    std::vector<std::vector<Vertex>> rows(size_t(res) * m.mFaces.size());
    std::vector<std::vector<uint32_t>> rowCounts(rows.size());
    // An orthographic map over one grey volume marches a row's texel rays together, eight at a
    // time where the build can (MarchParallelRays.h): parallel rays on one depth lattice.
    const bool byRow =
        m.mProjection == Projection::Orthographic && m.mGrey && vols.size() == 1 && vols[0]->density.channels() == 1;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rows.size()), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<Vertex> texel;
        std::vector<std::vector<Vertex>> rowRaw(byRow ? size_t(res) : 0);
        std::vector<int> toMarch;
        for (size_t row = r.begin(); row != r.end(); ++row) {
            throwIfStopped(settings.stop);  // before the row and, below, after its marches
            int face = int(row / res), iy = int(row % res);
            auto meets = [&](int ix) {
                return texelMeetsBricks.empty() || texelMeetsBricks[row * size_t(res) + size_t(ix)];
            };
            if (byRow) {
                toMarch.clear();
                for (int ix = 0; ix < res; ++ix)
                    if (meets(ix))
                        toMarch.push_back(ix);
                m.marchTexelRow(volumes, face, iy, toMarch, rowRaw);
                throwIfStopped(settings.stop);
            }
            for (int ix = 0; ix < res; ++ix) {
                const size_t t = row * size_t(res) + size_t(ix);
                std::vector<float>* samples = keep ? &sampleRows[row] : nullptr;
                TexelSamples* where = keep ? &sampleIndex[t] : nullptr;
                const float zStop = stops.empty() ? INFINITY : stops[t];
                if (!meets(ix)) {
                    if (zStop < INFINITY) {  // no density, but a shadow caster
                        m.finishTexel({}, texel, samples, where, zStop);
                    } else {
                        texel.clear();  // what the march would find: no density, an empty function
                        if (keep)
                            sampleIndex[t] = {0, kEmptyTexel, 0};
                    }
                } else if (byRow) {
                    m.finishTexel(rowRaw[size_t(ix)], texel, samples, where, zStop);
                } else {
                    m.buildTexel(volumes, face, ix, iy, texel, samples, where, zStop);
                    throwIfStopped(settings.stop);
                }
                rows[row].insert(rows[row].end(), texel.begin(), texel.end());
                rowCounts[row].push_back(uint32_t(texel.size()));
            }
        }
    });
    // Rows were built in parallel; concatenate them, in parallel, each row's texels starting
    // where the rows before it end.
    std::vector<size_t> rowStart(rows.size() + 1, 0);
    for (size_t row = 0; row < rows.size(); ++row)
        rowStart[row + 1] = rowStart[row] + rows[row].size();
    if (rowStart.back() > size_t(UINT32_MAX))
        throw Error("deep shadow map: more than 2^32 vertices; lower the shadow-map resolution");
    m.mOffsets.resize(texels + 1);
    m.mVertices.resize(rowStart.back());  // BulkVector: filled below, not zeroed first
    // The kept samples end to end after two zeros, with per-texel indices (DeepShadowMap.h).
    std::vector<size_t> sampleStart(sampleRows.size() + 1, 2);
    for (size_t row = 0; row < sampleRows.size(); ++row)
        sampleStart[row + 1] = sampleStart[row] + sampleRows[row].size();
    if (keep) {
        m.mSamples.resize(sampleStart.back());
        m.mSamples[0] = m.mSamples[1] = 0.0f;
        m.mSampleBase.resize(texels), m.mSampleLo.resize(texels), m.mSampleHi.resize(texels);
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rows.size()), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t row = r.begin(); row != r.end(); ++row) {
            uint32_t offset = uint32_t(rowStart[row]);
            uint32_t* texelOffset = m.mOffsets.data() + row * size_t(res);
            for (uint32_t count : rowCounts[row]) {
                *texelOffset++ = offset;
                offset += count;
            }
            std::copy(rows[row].begin(), rows[row].end(), m.mVertices.begin() + ptrdiff_t(rowStart[row]));
            std::vector<Vertex>().swap(rows[row]);
            if (keep) {
                std::copy(sampleRows[row].begin(), sampleRows[row].end(),
                          m.mSamples.begin() + ptrdiff_t(sampleStart[row]));
                std::vector<float>().swap(sampleRows[row]);
                for (size_t t = row * size_t(res); t < (row + 1) * size_t(res); ++t) {
                    const TexelSamples& ts = sampleIndex[t];
                    if (ts.first == kEmptyTexel) {  // the two leading zeros
                        m.mSampleBase[t] = m.mSampleLo[t] = m.mSampleHi[t] = 0;
                        continue;
                    }
                    const int32_t first = int32_t(sampleStart[row] + ts.first);
                    m.mSampleLo[t] = first - 1;
                    m.mSampleHi[t] = first + int32_t(ts.count) - 1;
                    m.mSampleBase[t] = first - ts.k0;
                }
            }
        }
    });
    m.mOffsets[texels] = uint32_t(rowStart.back());
    m.mStop = nullptr;  // the flag is the render's; the map may outlive it (ShadowMapCache)
    m.mBuildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return m;
}

std::vector<char> DeepShadowMap::texelsMeetingBricks(const VolumeSet& volumes) const
{
    // Texel (ix, iy)'s ray crosses the plane at fx = ix, fy = iy in texel units (centres at
    // integers). A brick's trilinear support, index box [origin, origin + 8]^3, projects inside
    // the rectangle of its corners' projections; a ray outside every such rectangle meets no
    // density. Half a texel of margin for rounding.
    const Face& f = mFaces[0];
    const float scale = float(mRes) / f.extent;
    std::vector<char> meets(size_t(mRes) * size_t(mRes), 0);
    for (const auto& v : volumes.volumes())
        forEachOccupiedBrick(v->density, v->worldFromIndex, [&](const float3* corners) {
            float xLo = 1e30f, xHi = -1e30f, yLo = 1e30f, yHi = -1e30f;
            for (int i = 0; i < 8; ++i) {
                const float3 q = corners[i] - f.origin;
                const float fx = dot(q, f.right) * scale - 0.5f, fy = dot(q, f.up) * scale - 0.5f;
                xLo = std::min(xLo, fx), xHi = std::max(xHi, fx), yLo = std::min(yLo, fy), yHi = std::max(yHi, fy);
            }
            const int x0 = std::max(0, int(std::ceil(xLo - 0.5f))),
                      x1 = std::min(mRes - 1, int(std::floor(xHi + 0.5f)));
            const int y0 = std::max(0, int(std::ceil(yLo - 0.5f))),
                      y1 = std::min(mRes - 1, int(std::floor(yHi + 0.5f)));
            if (x0 > x1)
                return true;  // beside the map (cannot happen: the footprint covers the bounds)
            for (int y = y0; y <= y1; ++y)
                std::fill(meets.begin() + ptrdiff_t(size_t(y) * mRes + x0),
                          meets.begin() + ptrdiff_t(size_t(y) * mRes + x1 + 1), char(1));
            return true;
        });
    return meets;
}

void DeepShadowMap::marchRay(const VolumeSet& volumes, float3 o, float3 d, float stepFraction, std::vector<Vertex>& raw,
                             const StopFlag* stop)
{
    raw.clear();
    // Polled every kStopPollInterval samples: a texel ray is 1 / shadow_step samples per voxel.
    unsigned polled = 0;
    auto goOn = [&] { return ++polled % kStopPollInterval != 0 || !stopRaised(stop); };
    float tau[3] = {0, 0, 0};
    if (volumes.volumes().size() == 1 && volumes.volumes()[0]->density.channels() == 1) {
        // One volume: walk its occupied bricks in index space (BrickWalk.h), midpoint rule on
        // the lattice t_k = (k + 1/2) dt from the ray's origin (so every texel ray of an
        // orthographic map, starting on its plane, samples the same depths); a vertex where a
        // run of samples starts and at the end of every step, so on the depths k dt.
        const VolumeData& vol = *volumes.volumes()[0];
        const BrickGrid& density = vol.density;
        const Rgb kT = vol.sigmaT();
        const float dt = stepFraction * vol.voxelSize;
        int last = -2;
        walkVolume(
            vol, o, d, dt, 0.5f,
            [&](int k, float t, const BrickGrid::Stencil& st) {
                if (k != last + 1)
                    raw.push_back({t - 0.5f * dt, {tau[0], tau[1], tau[2]}});
                last = k;
                const float rho = std::max(
                    BrickGrid::trilinear<1>(density.brickData(st.brick) + st.corner, st.tx, st.ty, st.tz), 0.0f);
                tau[0] += kT.x * rho * dt, tau[1] += kT.y * rho * dt, tau[2] += kT.z * rho * dt;
                raw.push_back({t + 0.5f * dt, {tau[0], tau[1], tau[2]}});
                return goOn();
            },
            Lattice::FromOrigin);
        return;
    }
    thread_local std::vector<Span> spanList;
    volumes.spans(o, d, 0.0f, 1e30f, stepFraction, spanList);
    for (const Span& s : spanList) {
        raw.push_back({s.t0, {tau[0], tau[1], tau[2]}});
        float len = s.t1 - s.t0;
        int n = stepCount(len, s.step);
        float dt = len / float(n);
        for (int k = 0; k < n; ++k) {
            Rgb c = volumes.sample(o + d * (s.t0 + (k + 0.5f) * dt)).sigma_t;
            tau[0] += c.x * dt, tau[1] += c.y * dt, tau[2] += c.z * dt;
            raw.push_back({s.t0 + (k + 1) * dt, {tau[0], tau[1], tau[2]}});
            if (!goOn())
                return;
        }
    }
}

void DeepShadowMap::buildTexel(const VolumeSet& volumes, int face, int ix, int iy, std::vector<Vertex>& out,
                               std::vector<float>* samples, TexelSamples* where, float zStop) const
{
    float3 o, d;
    texelRay(face, (ix + 0.5f) / mRes, (iy + 0.5f) / mRes, o, d);
    thread_local std::vector<Vertex> raw;
    marchRay(volumes, o, d, mStepFraction, raw, mStop);
    finishTexel(raw, out, samples, where, zStop);
}

std::vector<float> DeepShadowMap::texelStops(const EmbreeScene& casters) const
{
    const size_t perFace = size_t(mRes) * size_t(mRes);
    std::vector<float> stops(perFace * mFaces.size(), INFINITY);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, size_t(mRes) * mFaces.size()),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t row = r.begin(); row != r.end(); ++row) {
                              const int face = int(row / size_t(mRes)), iy = int(row % size_t(mRes));
                              for (int ix = 0; ix < mRes; ++ix) {
                                  float3 o, d;
                                  texelRay(face, (ix + 0.5f) / mRes, (iy + 0.5f) / mRes, o, d);
                                  // The texel ray's depth is its t (unit d from the plane or the
                                  // light). An orthographic map's plane lies just before the
                                  // volumes: a caster between it and the sun shadows the whole ray.
                                  float z = casters.shadowHit(o, d, 0.0f, INFINITY);
                                  if (mProjection == Projection::Orthographic && casters.occluded(o, -d, 0.0f, INFINITY))
                                      z = 0.0f;
                                  stops[row * size_t(mRes) + size_t(ix)] = z;
                              }
                          }
                      });
    return stops;
}

void DeepShadowMap::marchTexelRow(const VolumeSet& volumes, int face, int iy, const std::vector<int>& columns,
                                  std::vector<std::vector<Vertex>>& raw) const
{
#if NIMBUS_EIGHT_TEXEL_MARCH
    const VolumeData& vol = *volumes.volumes()[0];
    const float dt = mStepFraction * vol.voxelSize;  // marchRay's step
    for (size_t first = 0; first < columns.size(); first += 8) {
        const int n = int(std::min<size_t>(8, columns.size() - first));
        float3 o[8], d;
        std::vector<Vertex>* out[8];
        for (int i = 0; i < n; ++i) {
            const int ix = columns[first + size_t(i)];
            texelRay(face, (ix + 0.5f) / mRes, (iy + 0.5f) / mRes, o[i], d);
            out[i] = &raw[size_t(ix)];
        }
        if (!marchEightParallelRays(vol, o, n, d, dt, out, mStop))
            for (int i = 0; i < n; ++i)
                marchRay(volumes, o[i], d, mStepFraction, *out[i], mStop);
        if (stopRaised(mStop))
            return;  // the caller throws
    }
#else
    for (int ix : columns) {
        float3 o, d;
        texelRay(face, (ix + 0.5f) / mRes, (iy + 0.5f) / mRes, o, d);
        marchRay(volumes, o, d, mStepFraction, raw[size_t(ix)], mStop);
        if (stopRaised(mStop))
            return;  // the caller throws
    }
#endif
}

void DeepShadowMap::finishTexel(const std::vector<Vertex>& marched, std::vector<Vertex>& out,
                                std::vector<float>* samples, TexelSamples* where, float zStop) const
{
    const std::vector<Vertex>* rawp = &marched;
    thread_local std::vector<Vertex> stopped;
    if (zStop < INFINITY) {
        // The march before the caster, its optical depth at zStop (linear between the march's
        // vertices: across a gap between runs tau is constant), then the jump.
        stopped.clear();
        size_t i = 0;
        while (i < marched.size() && marched[i].z < zStop)
            stopped.push_back(marched[i++]);
        Vertex at{zStop, {0, 0, 0}};
        if (!stopped.empty()) {
            const Vertex& a = stopped.back();
            const float w = i < marched.size() ? (zStop - a.z) / (marched[i].z - a.z) : 0.0f;
            for (int c = 0; c < 3; ++c)
                at.tau[c] = a.tau[c] + w * (i < marched.size() ? marched[i].tau[c] - a.tau[c] : 0.0f);
        }
        stopped.push_back(at);
        compress(stopped, mTolerance, out, mGrey ? 1 : 3);
        if (out.empty() || out.back().z != zStop)
            out.push_back(at);
        Vertex behind = at;
        for (float& tau : behind.tau)
            tau += kOpaqueDepth;
        out.push_back(behind);
        stopped.push_back(behind);
        rawp = &stopped;
    } else {
        compress(marched, mTolerance, out, mGrey ? 1 : 3);
    }
    const std::vector<Vertex>& raw = *rawp;
    if (!samples)
        return;
    // marchRay's vertices lie on the depths k dz: runs of samples, with tau constant across
    // the empty bricks skipped between runs. Spread them onto every k from the first, between
    // a leading 0 and a copy of the last (so a lookup clamps its index instead of branching).
    where->count = 0;
    where->k0 = 0;
    if (out.empty()) {  // nothing along this ray
        where->first = kEmptyTexel;
        return;
    }
    samples->push_back(0.0f);
    const size_t first = samples->size();
    where->first = uint32_t(first);
    const float inv = 1.0f / mSampleDz;
    auto nearest = [&](float z) { return long(floorToInt(z * inv + 0.5f)); };  // not lround: a libm call
    where->k0 = int32_t(nearest(raw[0].z));
    long prev = long(where->k0) - 1;
    for (const Vertex& v : raw) {
        const long k = nearest(v.z);
        if (k <= prev) {  // rounding put two vertices on one k: the later one holds
            samples->back() = v.tau[0];
            continue;
        }
        samples->insert(samples->end(), size_t(k - prev - 1), samples->back());
        samples->push_back(v.tau[0]);
        prev = k;
    }
    where->count = uint32_t(samples->size() - first);
    samples->push_back(samples->back());
}

size_t DeepShadowMap::marchSampleBytes() const
{
    return mSamples.size() * sizeof(float) + 3 * mSampleBase.size() * sizeof(int32_t);
}

void DeepShadowMap::releaseMarchSamples()
{
    BulkVector<float>().swap(mSamples);
    BulkVector<int32_t>().swap(mSampleBase);
    BulkVector<int32_t>().swap(mSampleLo);
    BulkVector<int32_t>().swap(mSampleHi);
}

size_t DeepShadowMap::memoryBytes() const
{
    return mVertices.size() * sizeof(Vertex) + mOffsets.size() * sizeof(uint32_t);
}

}  // namespace nimbus
