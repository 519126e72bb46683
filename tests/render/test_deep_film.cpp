// DeepFilm's samples from a pixel's prefix curves (DeepFilm.h): flattening gives the whole march's
// light and alpha; a cut at a sample edge gives the prefix there; merging keeps its tolerance and
// the sample cap; curves that are not monotone still give non-negative samples.
#include "render/DeepFilm.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

using namespace nimbus;

namespace {

// A homogeneous slab between depths 2 and 6 seen through `slices` slices of [1, 7]: T(z) =
// exp(-sigma (z - 2)) inside, single-scattered light L(z) = S (1 - T(z)) (source S over sigma),
// background `bg` behind.
DeepCurve slabCurve(int slices, float sigma, Rgb S, Rgb bg)
{
    DeepCurve c;
    for (int k = 0; k <= slices; ++k)
        c.edges.push_back(1.0f + 6.0f * float(k) / float(slices));
    c.L.push_back(splat(0.0f));
    c.T.push_back(1.0f);
    for (int k = 1; k <= slices; ++k) {
        const float depth = std::min(4.0f, std::max(0.0f, c.edges[size_t(k)] - 2.0f));
        const float T = std::exp(-sigma * depth);
        c.T.push_back(T);
        c.L.push_back(S * (1.0f - T));
    }
    c.T.push_back(c.T.back());
    c.L.push_back(c.L.back() + bg * c.T.back());
    return c;
}

void expectNear(Rgb a, Rgb b, float tol)
{
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

}  // namespace

TEST(DeepFilm, FlatteningGivesTheWholeMarch)
{
    const Rgb S = make_float3(0.8f, 0.5f, 0.3f), bg = make_float3(0.1f, 0.2f, 0.3f);
    const DeepCurve curve = slabCurve(31, 0.7f, S, bg);
    const std::vector<DeepSample> samples = deepSamplesOf(curve, 32);
    ASSERT_LE(samples.size(), 32u);
    Rgb color;
    float alpha;
    flattenDeep(samples, color, alpha);
    expectNear(color, curve.L.back(), 1e-5f);
    EXPECT_NEAR(alpha, 1.0f - curve.T.back(), 1e-6f);
    // Sorted, non-overlapping, and the background last at infinity with alpha 0.
    for (size_t k = 0; k + 1 < samples.size(); ++k) {
        EXPECT_LE(samples[k].z, samples[k].zBack);
        EXPECT_LE(samples[k].zBack, samples[k + 1].z);
    }
    EXPECT_EQ(samples.back().z, std::numeric_limits<float>::max());
    EXPECT_EQ(samples.back().alpha, 0.0f);
    expectNear(samples.back().color, bg, 1e-6f);
    // Nothing in front of the slab or between it and the background: the first sample starts at
    // the slab's front slice.
    EXPECT_GE(samples.front().zBack, 2.0f);
}

TEST(DeepFilm, ACutAtASampleEdgeIsThePrefixThere)
{
    const DeepCurve curve = slabCurve(24, 0.9f, splat(1.0f), splat(0.0f));
    const std::vector<DeepSample> samples = deepSamplesOf(curve, 32);
    int checked = 0;
    for (size_t k = 1; k + 1 < curve.edges.size(); ++k) {
        const float z = curve.edges[k];
        std::vector<DeepSample> front;
        bool straddles = false;
        for (const DeepSample& s : samples) {
            if (s.zBack <= z)
                front.push_back(s);
            else if (s.z < z)
                straddles = true;
        }
        if (straddles)
            continue;  // a merged sample spans this edge
        Rgb color;
        float alpha;
        flattenDeep(front, color, alpha);
        expectNear(color, curve.L[k], 1e-5f);
        EXPECT_NEAR(alpha, 1.0f - curve.T[k], 1e-6f);
        ++checked;
    }
    EXPECT_GE(checked, 16);  // the slab's slices are far above the merge tolerance: kept apart
}

TEST(DeepFilm, MergingKeepsItsToleranceAndTheCap)
{
    // A faint medium: every slice is far below kDeepMergeAlpha, so slices merge up to it.
    const DeepCurve faint = slabCurve(31, 0.002f, splat(1.0f), splat(0.0f));
    const std::vector<DeepSample> merged = deepSamplesOf(faint, 32);
    ASSERT_LT(merged.size(), 31u);
    for (const DeepSample& s : merged)
        EXPECT_LE(s.alpha, kDeepMergeAlpha * (1.0f + 1e-5f));
    // A cap below the slices that hold anything: pairs merge, flattening is unchanged.
    const DeepCurve dense = slabCurve(31, 0.9f, make_float3(1.0f, 0.5f, 0.25f), splat(0.5f));
    for (int cap : {1, 2, 5, 12}) {
        const std::vector<DeepSample> s = deepSamplesOf(dense, cap);
        EXPECT_EQ(s.size(), size_t(cap));
        Rgb color;
        float alpha;
        flattenDeep(s, color, alpha);
        expectNear(color, dense.L.back(), 1e-5f);
        EXPECT_NEAR(alpha, 1.0f - dense.T.back(), 1e-6f);
    }
}

TEST(DeepFilm, NonMonotoneCurvesGiveNonNegativeSamplesAndFlattenExactly)
{
    // Noisy prefix estimates (emission scattering, wkb's traced order 2): L dips, T rises.
    std::mt19937 gen(7);
    std::uniform_real_distribution<float> u(-0.05f, 0.05f);
    DeepCurve c = slabCurve(20, 0.5f, splat(1.0f), splat(0.0f));
    for (size_t k = 1; k + 1 < c.L.size(); ++k) {
        c.L[k] += splat(u(gen));
        c.T[k] = std::min(1.0f, std::max(0.0f, c.T[k] + u(gen)));
    }
    const std::vector<DeepSample> samples = deepSamplesOf(c, 32);
    for (const DeepSample& s : samples) {
        EXPECT_GE(s.color.x, 0.0f);
        EXPECT_GE(s.alpha, 0.0f);
        EXPECT_LE(s.alpha, 1.0f);
    }
    Rgb color;
    float alpha;
    flattenDeep(samples, color, alpha);
    expectNear(color, c.L.back(), 1e-5f);
    EXPECT_NEAR(alpha, 1.0f - c.T.back(), 1e-6f);
}

TEST(DeepFilm, AnEmptyPixelHasNoSamples)
{
    const DeepCurve empty = slabCurve(8, 0.0f, splat(0.0f), splat(0.0f));
    EXPECT_TRUE(deepSamplesOf(empty, 32).empty());
}
