#include "MarchParallelRays.h"

#include "BrickLanes.h"

#include <cmath>
#include <cstdint>

namespace nimbus {

#if NIMBUS_EIGHT_TEXEL_MARCH

bool marchEightParallelRays(const VolumeData& vol, const float3* o, int n, float3 d, float dt,
                            std::vector<DeepShadowMap::Vertex>* const* raw, const StopFlag* stop)
{
    const BrickGrid& density = vol.density;
    if (!lanes::gatherable(density) || !(dt > 0.0f))
        return false;
    const float kT = vol.sigmaT().x;
    const float invDt = 1.0f / dt;
    const float3 di = vol.indexFromWorld.vector(d);
    const float3 invD = safeInverse(d), invDi = safeInverse(di);

    // Each ray clipped as walkVolume clips it (world bounds, then the occupied bricks' index
    // bounds); its first sample k is the scalar walk's, ceil(t_in / dt - 1/2).
    constexpr int kLongestMarch = 1 << 22;  // sample indices as floats stay exact
    alignas(32) float ox[8], oy[8], oz[8], tOut[8], kFirst[8];
    int kLo = INT32_MAX, kHi = INT32_MIN;
    for (int i = 0; i < 8; ++i) {
        ox[i] = oy[i] = oz[i] = tOut[i] = 0.0f;
        kFirst[i] = 1.0f;  // with tOut 0: never sampled
        if (i >= n)
            continue;
        raw[i]->clear();
        const float3 oi = vol.indexFromWorld.point(o[i]);
        float t0, t1, s0, s1;
        if (!vol.worldBounds.intersect(o[i], invD, 0.0f, 1e30f, t0, t1) ||
            !density.activeIndexBounds().intersect(oi, invDi, t0, t1, s0, s1) || !(s1 > s0))
            continue;
        const float3 p = oi + di * s0;
        if (!(std::fabs(p.x) < 1e9f && std::fabs(p.y) < 1e9f && std::fabs(p.z) < 1e9f))
            continue;  // as BrickDda::start: nothing to walk
        const float first = std::ceil(s0 * invDt - 0.5f), last = std::ceil(s1 * invDt - 0.5f);
        if (!(last - first < float(kLongestMarch)) || !(last < float(kLongestMarch)))
            return false;
        ox[i] = oi.x, oy[i] = oi.y, oz[i] = oi.z, tOut[i] = s1, kFirst[i] = first;
        kLo = std::min(kLo, int(first));
        kHi = std::max(kHi, int(last));
    }
    if (kLo > kHi)
        return true;  // no ray meets the occupied bricks

    // Per step k from kLo: each lane's optical depth after the step, and which lanes sampled.
    thread_local std::vector<float> tauAfter;
    thread_local std::vector<uint8_t> sampled;
    const size_t steps = size_t(kHi - kLo) + 1;
    tauAfter.resize(8 * steps);
    sampled.resize(steps);

    const __m256 Ox = _mm256_load_ps(ox), Oy = _mm256_load_ps(oy), Oz = _mm256_load_ps(oz);
    const __m256 TOut = _mm256_load_ps(tOut), KFirst = _mm256_load_ps(kFirst);
    const __m256 Dx = _mm256_set1_ps(di.x), Dy = _mm256_set1_ps(di.y), Dz = _mm256_set1_ps(di.z);
    const __m256 KT = _mm256_set1_ps(kT), Dt = _mm256_set1_ps(dt), zero = _mm256_setzero_ps();
    const lanes::BrickTable table(density);
    const float* rhoPool = density.pool().data();
    __m256 tau = zero;
    for (size_t s = 0; s < steps; ++s) {
        if (s % kStopPollInterval == kStopPollInterval - 1 && stopRaised(stop))
            return true;  // a stopped render: the build throws Cancelled and drops the rows
        const float kf = float(kLo + int(s));
        const float t = 0.0f + (kf + 0.5f) * dt;  // walkOccupiedBricks' t_k, tStart 0, jitter 1/2
        const __m256 tk = _mm256_set1_ps(t), K = _mm256_set1_ps(kf);
        const __m256 alive = _mm256_and_ps(_mm256_cmp_ps(K, KFirst, _CMP_GE_OQ), _mm256_cmp_ps(tk, TOut, _CMP_LT_OQ));
        uint8_t mask = 0;
        if (!lanes::none(alive)) {
            const __m256 qx = _mm256_fmadd_ps(Dx, tk, Ox), qy = _mm256_fmadd_ps(Dy, tk, Oy),
                         qz = _mm256_fmadd_ps(Dz, tk, Oz);
            __m256 cellX, cellY, cellZ;
            const __m256i brick = table.brickAt(qx, qy, qz, alive, cellX, cellY, cellZ);
            const __m256 occ = _mm256_castsi256_ps(_mm256_cmpgt_epi32(brick, _mm256_set1_epi32(-1)));
            mask = uint8_t(_mm256_movemask_ps(occ));
            if (mask) {
                const lanes::Stencil8 st = lanes::stencilAt(brick, occ, qx, qy, qz, cellX, cellY, cellZ);
                const __m256 rho = _mm256_and_ps(occ, _mm256_max_ps(lanes::trilinear(rhoPool, st), zero));
                tau = _mm256_add_ps(tau, _mm256_mul_ps(_mm256_mul_ps(KT, rho), Dt));  // marchRay: kT rho dt
            }
        }
        sampled[s] = mask;
        _mm256_storeu_ps(tauAfter.data() + 8 * s, tau);
    }

    // marchRay's vertices per ray: where a run of samples starts, the depth before it with the
    // optical depth so far; after every sample, the end of its step.
    for (int i = 0; i < n; ++i) {
        int last = -2;
        float before = 0.0f;
        for (size_t s = 0; s < steps; ++s) {
            if (!(sampled[s] >> i & 1))
                continue;
            const int k = kLo + int(s);
            const float t = 0.0f + (float(k) + 0.5f) * dt;
            if (k != last + 1)
                raw[i]->push_back({t - 0.5f * dt, {before, before, before}});
            last = k;
            before = tauAfter[8 * s + size_t(i)];
            raw[i]->push_back({t + 0.5f * dt, {before, before, before}});
        }
    }
    return true;
}

#endif

}  // namespace nimbus
