// ShadowMapMarchSamples.h: the lookups in a deep shadow map's kept march samples
// (DeepShadowMap::greyMarchedDepthRow, DeepShadowMap.h), one point at a time and, where the CPU
// has AVX2 and FMA, eight lanes at once with gathers. Inline because the light cache's bake calls
// them once per row of voxels; apart from the class so that DeepShadowMap.h reads as its
// interface. Included at the end of DeepShadowMap.h, not on its own.
#pragma once

#include <algorithm>
#include <cmath>

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

namespace nimbus {

inline void DeepShadowMap::greyMarchedDepthRow(float fx, float fy, float zSteps, float dx, float dy, float dz, int n,
                                               float* out) const
{
    const float last = float(mRes) - 0.5f;
    const int32_t* base = mSampleBase.data();
    const int32_t* lo = mSampleLo.data();
    const int32_t* hi = mSampleHi.data();
    const float* tau = mSamples.data();
    const int res = mRes;
#if defined(__AVX2__) && defined(__FMA__)
    if (n == 8) {  // the bake's rows: the loop below, eight lanes at once with gathers
        greyMarchedDepthRow8(fx, fy, zSteps, dx, dy, dz, out);
        return;
    }
#endif
    for (int i = 0; i < n; ++i) {
        const float x = fx + float(i) * dx, y = fy + float(i) * dy, z = zSteps + float(i) * dz;
        // Outside [0, 1] in u or v (as in opticalDepthAt), or on or before the map's plane
        // (before every ray's first vertex): 0. Every index below stays in range anyway
        // (a point clamped to x = res reads texel res - 1, masked out).
        const bool inside = (x >= -0.5f) & (x <= last) & (y >= -0.5f) & (y <= last) & (z > 0.0f);
        const float xc = std::min(std::max(x, -1.0f), float(res)), yc = std::min(std::max(y, -1.0f), float(res));
        const float zc = z > 0.0f ? std::min(z, 1e9f) : 0.0f;
        const int x0 = int(std::floor(xc)), y0 = int(std::floor(yc)), j = int(zc);
        const float wx = xc - float(x0), wy = yc - float(y0), w = zc - float(j);
        // x0, y0 lie in [-1, res]: both neighbours clamped into [0, res - 1].
        const int xa = std::min(std::max(x0, 0), res - 1), xb = std::min(x0 + 1, res - 1);
        const int ra = std::min(std::max(y0, 0), res - 1) * res, rb = std::min(y0 + 1, res - 1) * res;
        // One depth lattice for every texel: the step j and weight w are shared; a texel's
        // samples run from lo + 1 (depth k0) to hi, with a 0 at lo and a copy after hi.
        auto at = [&](int t) {
            const int k = std::min(std::max(j + base[t], lo[t]), hi[t]);
            return tau[k] + w * (tau[k + 1] - tau[k]);
        };
        const float a = at(ra + xa), b = at(ra + xb), c = at(rb + xa), d = at(rb + xb);
        const float top = a + wx * (b - a), bottom = c + wx * (d - c);
        out[i] = inside ? top + wy * (bottom - top) : 0.0f;
    }
}

#if defined(__AVX2__) && defined(__FMA__)
inline void DeepShadowMap::greyMarchedDepthRow8(float fx, float fy, float zSteps, float dx, float dy, float dz,
                                                float* out) const
{
    const __m256 lane = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256 x = _mm256_fmadd_ps(lane, _mm256_set1_ps(dx), _mm256_set1_ps(fx));
    const __m256 y = _mm256_fmadd_ps(lane, _mm256_set1_ps(dy), _mm256_set1_ps(fy));
    const __m256 z = _mm256_fmadd_ps(lane, _mm256_set1_ps(dz), _mm256_set1_ps(zSteps));
    const __m256 last = _mm256_set1_ps(float(mRes) - 0.5f), half = _mm256_set1_ps(-0.5f), zero = _mm256_setzero_ps();
    const __m256 inside = _mm256_and_ps(
        _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(x, half, _CMP_GE_OQ), _mm256_cmp_ps(x, last, _CMP_LE_OQ)),
                      _mm256_and_ps(_mm256_cmp_ps(y, half, _CMP_GE_OQ), _mm256_cmp_ps(y, last, _CMP_LE_OQ))),
        _mm256_cmp_ps(z, zero, _CMP_GT_OQ));
    const __m256 lowest = _mm256_set1_ps(-1.0f), highest = _mm256_set1_ps(float(mRes));
    const __m256 xc = _mm256_min_ps(_mm256_max_ps(x, lowest), highest);
    const __m256 yc = _mm256_min_ps(_mm256_max_ps(y, lowest), highest);
    const __m256 zc = _mm256_and_ps(_mm256_min_ps(z, _mm256_set1_ps(1e9f)), _mm256_cmp_ps(z, zero, _CMP_GT_OQ));
    const __m256 x0f = _mm256_floor_ps(xc), y0f = _mm256_floor_ps(yc), jf = _mm256_floor_ps(zc);
    const __m256 wx = _mm256_sub_ps(xc, x0f), wy = _mm256_sub_ps(yc, y0f), w = _mm256_sub_ps(zc, jf);
    const __m256i x0 = _mm256_cvttps_epi32(x0f), y0 = _mm256_cvttps_epi32(y0f), j = _mm256_cvttps_epi32(jf);
    const __m256i izero = _mm256_setzero_si256(), one = _mm256_set1_epi32(1), top = _mm256_set1_epi32(mRes - 1);
    const __m256i resV = _mm256_set1_epi32(mRes);
    const __m256i xa = _mm256_min_epi32(_mm256_max_epi32(x0, izero), top);
    const __m256i xb = _mm256_min_epi32(_mm256_add_epi32(x0, one), top);
    const __m256i ra = _mm256_mullo_epi32(_mm256_min_epi32(_mm256_max_epi32(y0, izero), top), resV);
    const __m256i rb = _mm256_mullo_epi32(_mm256_min_epi32(_mm256_add_epi32(y0, one), top), resV);
    auto at = [&](__m256i t) {
        const __m256i b = _mm256_i32gather_epi32(mSampleBase.data(), t, 4);
        const __m256i l = _mm256_i32gather_epi32(mSampleLo.data(), t, 4);
        const __m256i h = _mm256_i32gather_epi32(mSampleHi.data(), t, 4);
        const __m256i k = _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(j, b), l), h);
        const __m256 t0 = _mm256_i32gather_ps(mSamples.data(), k, 4);
        const __m256 t1 = _mm256_i32gather_ps(mSamples.data() + 1, k, 4);
        return _mm256_fmadd_ps(w, _mm256_sub_ps(t1, t0), t0);
    };
    const __m256 a = at(_mm256_add_epi32(ra, xa)), b = at(_mm256_add_epi32(ra, xb));
    const __m256 c = at(_mm256_add_epi32(rb, xa)), d = at(_mm256_add_epi32(rb, xb));
    const __m256 upper = _mm256_fmadd_ps(wx, _mm256_sub_ps(b, a), a);
    const __m256 lower = _mm256_fmadd_ps(wx, _mm256_sub_ps(d, c), c);
    _mm256_storeu_ps(out, _mm256_and_ps(_mm256_fmadd_ps(wy, _mm256_sub_ps(lower, upper), upper), inside));
}
#endif

}  // namespace nimbus
