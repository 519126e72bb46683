// ExpNeg.h: e^{-x}, the transmittance of optical depth x, in single precision without a libm call.
//
// The single-scattering march takes two per sample (the step's transmittance and the light's);
// glibc's expf is a call with its own special-case checks. Here: e^{-x} = 2^{-k} e^{k ln2 - x}
// with k = round(x / ln 2), so the reduced argument r = k ln2 - x lies in [-ln2/2, ln2/2], and
// e^r by its degree-6 Taylor polynomial (truncation |r|^7/7! <= 1.2e-7 relative), the power of
// two by exponent bits. Relative error within 3e-7 of std::exp over the clamp range (tested in
// test_expneg). x is clamped to [-87, 87]: e^{-87} = 1.6e-38, the smallest normal float
// magnitude, below which every caller treats the medium as opaque.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

namespace nimbus {

// Always inlined: every call sits in a hot loop, and the camera march's many instances must not
// tip the inliner into calls (whose boundary also changes how the arithmetic fuses).
[[gnu::always_inline]] inline float expNeg(float x)
{
    x = std::min(std::max(x, -87.0f), 87.0f);  // (a NaN stays NaN, as in std::exp)
    const float k = std::floor(x * 1.44269504089f + 0.5f);
    // k ln2 in two parts (Cody-Waite), so r keeps full precision.
    const float r = std::fma(k, 0.693145751953125f, -x) + k * 1.428606765330187e-06f;
    float p = 1.0f / 720.0f;
    p = std::fma(p, r, 1.0f / 120.0f);
    p = std::fma(p, r, 1.0f / 24.0f);
    p = std::fma(p, r, 1.0f / 6.0f);
    p = std::fma(p, r, 0.5f);
    p = std::fma(p, r, 1.0f);
    p = std::fma(p, r, 1.0f);
    // 2^{-k}, k in [-126, 126]; a NaN k (x NaN: p is NaN already) must not reach the int
    // conversion, undefined behaviour (UBSan in the sanitized build, test_expneg).
    const int32_t bits = (127 - int32_t(k == k ? k : 0.0f)) << 23;
    float scale;
    std::memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

#if defined(__AVX2__) && defined(__FMA__)
// expNeg in eight lanes, the same arithmetic (the eight-ray camera march, MarchEightRays.cpp).
inline __m256 expNeg8(__m256 x)
{
    // (max_ps and min_ps return their second operand where either is NaN: a NaN stays NaN)
    x = _mm256_min_ps(_mm256_set1_ps(87.0f), _mm256_max_ps(_mm256_set1_ps(-87.0f), x));
    const __m256 k = _mm256_floor_ps(_mm256_fmadd_ps(x, _mm256_set1_ps(1.44269504089f), _mm256_set1_ps(0.5f)));
    const __m256 r = _mm256_fmadd_ps(k, _mm256_set1_ps(1.428606765330187e-06f),
                                     _mm256_fmsub_ps(k, _mm256_set1_ps(0.693145751953125f), x));
    __m256 p = _mm256_set1_ps(1.0f / 720.0f);
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0f / 120.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0f / 24.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0f / 6.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(0.5f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0f));
    const __m256i bits = _mm256_slli_epi32(_mm256_sub_epi32(_mm256_set1_epi32(127), _mm256_cvttps_epi32(k)), 23);
    return _mm256_mul_ps(p, _mm256_castsi256_ps(bits));
}
#endif

}  // namespace nimbus
