// PixelStrata.h: where in its pixel each of a pixel's camera samples falls (the marching
// integrators, single and wkb: engine/TileDriver.cpp).
//
// The pixel's spp samples are stratified in 2D: the pixel (the pixel filter's CDF domain, [0,1)^2)
// is cut into an m x n grid of C = m n strata, m = ceil(sqrt(spp)), n = ceil(spp / m), and sample
// s takes stratum ((s + r) g) mod C, then a uniform point within it: r uniform in [0, C) from the
// seed and the pixel (a rotation), g coprime with C near 0.618 C (so that consecutive samples land
// far apart). For every s that stratum is uniform over the C strata (r is), so each sample is
// uniform over the pixel and every estimate keeps its mean; no two of a pixel's samples share a
// stratum (j -> j g mod C is a bijection), so they no longer fall on top of each other, which is
// what leaves a cloud's edges noisy at a few samples per pixel (the validation suite's
// cumulus_against at 4 spp: beauty relMSE 0.0270 with independent samples, 0.0134 stratified;
// docs/validation.md "Stratified pixel samples"). Where spp is a square this is the jittered grid.
// Each sample is made from its own index (the rays of a pixel are made in any order, on any thread).
// The shutter time is stratified in 1D too (stratifiedTime, by a shuffle independent of the
// point's strata): with camera or volume motion a pixel's samples cover the shutter evenly.
#pragma once

#include "../../kernels/shared/rng.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace nimbus {

// The stride g of stratumOf: the integer nearest 0.618 count that is coprime with count.
inline uint32_t stratumStride(uint32_t count)
{
    auto gcd = [](uint32_t a, uint32_t b) {
        while (b) {
            const uint32_t t = a % b;
            a = b;
            b = t;
        }
        return a;
    };
    uint32_t g = std::max(1u, uint32_t(0.6180339887 * double(count) + 0.5));
    while (gcd(g, count) != 1)
        ++g;
    return g;
}

// The stratum of sample s among `count` (count >= 1), rotation r in [0, count).
inline uint32_t stratumOf(uint32_t s, uint32_t count, uint32_t r)
{
    return uint32_t((uint64_t((s % count + r) % count) * stratumStride(count)) % count);
}

// Sample s of spp in its pixel: (u0, u1) uniform in [0, 1)^2 (the sample's own random numbers) to
// a point in [0, 1)^2 of its stratum. key: a 32-bit hash of the seed and the pixel.
inline void stratifiedPixelPoint(int s, int spp, uint32_t key, float u0, float u1, float& x, float& y)
{
    if (spp <= 1) {
        x = u0, y = u1;
        return;
    }
    const int m = int(std::ceil(std::sqrt(double(spp))));
    const int n = (spp + m - 1) / m;
    const uint32_t count = uint32_t(m * n);
    const uint32_t stratum = stratumOf(uint32_t(s), count, uint32_t((uint64_t(key) * count) >> 32));
    const int sx = int(stratum % uint32_t(m)), sy = int(stratum / uint32_t(m));
    x = std::fmin((float(sx) + u0) / float(m), 0x1.fffffep-1f);
    y = std::fmin((float(sy) + u1) / float(n), 0x1.fffffep-1f);
}

// Sample s of spp's shutter time in [0, 1): u uniform in [0, 1) to a point of stratum perm(s) of
// spp equal strata, perm a uniformly random permutation keyed by `key` (a Fisher-Yates shuffle
// run up to s, kTimeStrataMax strata at most; above that the time is u itself). Not the pixel
// point's rotation: two affine maps of s would tie each sample's time to its place in the pixel
// (sideways camera motion then smeared along lines), and the shuffle is independent of it. Its
// cost grows with s: 0.006, 0.019, 0.097 and 0.37 us per sample at 4, 16, 64 and 256 spp
// (measured on this project's machine, against several us for a sample's march).
constexpr int kTimeStrataMax = 256;

inline float stratifiedTime(int s, int spp, uint32_t key, float u)
{
    if (spp <= 1 || spp > kTimeStrataMax)
        return u;
    uint16_t order[kTimeStrataMax];
    for (int i = 0; i < spp; ++i)
        order[i] = uint16_t(i);
    uint64_t state = (uint64_t(key) << 1) | 1u;
    for (int i = 0; i <= s; ++i) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;  // an LCG step; its high bits
        const int j = i + int(((state >> 32) * uint64_t(spp - i)) >> 32);
        const uint16_t t = order[i];
        order[i] = order[j];
        order[j] = t;
    }
    return std::fmin((float(order[s]) + u) / float(spp), 0x1.fffffep-1f);
}

// The random numbers of camera sample s (of spp) of pixel `pixel` (y width + x): (ux, uy) in
// [0, 1)^2 for the pixel filter's importance sampling, and the shutter time in [0, 1). rng: the
// sample's own stream, nbRngStart(seed, pixel, s), advanced past its three numbers (the
// integrators draw the rest of theirs after them). Tests that replay the renderer's rays call it.
struct PixelSampleNumbers {
    float ux, uy, time;
};

inline PixelSampleNumbers pixelSampleNumbers(uint32_t seed, uint32_t pixel, int s, int spp, NbRng& rng)
{
    const float u0 = nbRngNext(&rng), u1 = nbRngNext(&rng), u2 = nbRngNext(&rng);
    const uint32_t key = nbPcgHash(nbPcgHash(pixel) ^ seed);
    PixelSampleNumbers n;
    stratifiedPixelPoint(s, spp, key, u0, u1, n.ux, n.uy);
    n.time = stratifiedTime(s, spp, nbPcgHash(key ^ 0x74696d65u), u2);
    return n;
}

}  // namespace nimbus
