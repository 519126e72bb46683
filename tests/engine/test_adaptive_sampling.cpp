// Adaptive pixel sampling for single and wkb (src/render/AdaptiveSampling.h, render.adaptive_threshold
// and render.adaptive_max_spp): the rule against closed forms, and renders where it must put its
// samples on the noisy pixels, beat uniform sampling at the same sample count, and keep the image's
// mean.
#include "../render/SceneBuilders.h"

#include "engine/Renderer.h"
#include "render/AdaptiveSampling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>

using namespace nimbus;
using namespace nimbus::test;

namespace {

// A homogeneous box seen corner-on against a black background, lit by a sun: the pixels its
// silhouette crosses are noisy at a few samples (part of each pixel is empty), those inside it
// nearly smooth (the march's jitter alone), those outside it black.
Scene boxEdgeScene()
{
    Scene s = emptyScene(48, 36);
    s.volumes.push_back(homogeneousBox(1.2f, 1.0f, 0.8f, 0.05f, splat(3.0f), splat(0.3f), 0.3f));
    s.lights.push_back(distantLight("sun", make_float3(0.4f, -1.0f, -0.5f), splat(3.0f)));
    s.camera.from = make_float3(2.6f, 1.7f, 3.4f);
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 40.0f;
    s.render.method = Method::Single;
    s.render.spp = 4;
    return s;
}

std::vector<double> beautyLuminance(const RenderResult& r)
{
    const Aov* b = r.film.find("beauty");
    std::vector<double> out(b->pixels.size() / 4);
    for (size_t p = 0; p < out.size(); ++p)
        out[p] = (double(b->pixels[4 * p]) + b->pixels[4 * p + 1] + b->pixels[4 * p + 2]) / 3.0;
    return out;
}

// nimbus compare's relMSE (ErrorMetrics.cpp) on luminance: eps a tenth of the reference's mean, squared.
double relMse(const std::vector<double>& x, const std::vector<double>& ref)
{
    double mean = 0;
    for (double v : ref)
        mean += v;
    mean /= double(ref.size());
    const double eps = (0.1 * mean) * (0.1 * mean);
    double e = 0;
    for (size_t p = 0; p < x.size(); ++p)
        e += (x[p] - ref[p]) * (x[p] - ref[p]) / (ref[p] * ref[p] + eps);
    return e / double(x.size());
}

double sum(const std::vector<double>& x)
{
    double s = 0;
    for (double v : x)
        s += v;
    return s;
}

}  // namespace

TEST(AdaptiveSampling, MomentsAreTheSamplesMeanAndTheVarianceOfTheirMean)
{
    PixelMoments m;
    EXPECT_EQ(m.varianceOfMean(), 0.0);
    for (double v : {1.0, 2.0, 3.0, 4.0})
        m.add(v);
    EXPECT_EQ(m.n, 4);
    EXPECT_DOUBLE_EQ(m.mean(), 2.5);
    // s^2 = ((1.5^2 + 0.5^2) * 2) / 3 = 5 / 3; over n = 4: 5 / 12.
    EXPECT_NEAR(m.varianceOfMean(), 5.0 / 12.0, 1e-12);
    PixelMoments one;
    one.add(7.0);
    EXPECT_EQ(one.varianceOfMean(), 0.0);
}

TEST(AdaptiveSampling, NoisyPixelsDoubleTheirSamplesUpToTheMostAndQuietOnesStop)
{
    AdaptiveSampling a;
    a.threshold = 0.02;
    a.maxSpp = 16;
    PixelMoments quiet, noisy, single;
    for (int k = 0; k < 4; ++k) {
        quiet.add(1.0 + 0.001 * k);    // standard error 0.00065: 0.065% of the mean
        noisy.add(k % 2 ? 1.5 : 0.5);  // standard error 0.289: 29% of the mean
    }
    single.add(1.0);
    EXPECT_EQ(a.moreSamples(quiet), 0);
    EXPECT_EQ(a.moreSamples(noisy), 4);
    EXPECT_EQ(a.moreSamples(single), 0);  // no variance from one sample: spp 1 stays a preview's 1
    for (int k = 0; k < 8; ++k)
        noisy.add(k % 2 ? 1.5 : 0.5);
    EXPECT_EQ(a.moreSamples(noisy), 4);  // 12 samples: 4 more reach the most
    for (int k = 0; k < 4; ++k)
        noisy.add(k % 2 ? 1.5 : 0.5);
    EXPECT_EQ(a.moreSamples(noisy), 0);
    // A pixel that is black in every sample is done; one that is black in all but one is not.
    PixelMoments black, spark;
    for (int k = 0; k < 4; ++k)
        black.add(0.0), spark.add(k == 3 ? 1.0 : 0.0);
    EXPECT_EQ(a.moreSamples(black), 0);
    EXPECT_EQ(a.moreSamples(spark), 4);
    // The threshold either side of a pixel's relative standard error (0.289 / 1 here).
    PixelMoments four;
    for (int k = 0; k < 4; ++k)
        four.add(k % 2 ? 1.5 : 0.5);
    const double relative = std::sqrt(four.varianceOfMean()) / four.mean();
    EXPECT_NEAR(relative, 0.5 / std::sqrt(3.0), 1e-12);
    AdaptiveSampling around = a;
    around.threshold = relative * 1.001;
    EXPECT_EQ(around.moreSamples(four), 0);
    around.threshold = relative * 0.999;
    EXPECT_EQ(around.moreSamples(four), 4);
}

TEST(AdaptiveSampling, TheScenesKeysTurnItOnAndOff)
{
    RenderSettings r;
    EXPECT_EQ(r.adaptiveThreshold, 0.05);  // on by default
    AdaptiveSampling a = adaptiveSamplingOf(r, 4);
    EXPECT_TRUE(a.enabled());
    EXPECT_EQ(a.maxSpp, 16);  // 0: 4 x spp
    r.adaptiveMaxSpp = 4;
    EXPECT_FALSE(adaptiveSamplingOf(r, 4).enabled());  // at spp: off
    r.adaptiveMaxSpp = 9;
    EXPECT_EQ(adaptiveSamplingOf(r, 4).maxSpp, 9);
    r.adaptiveMaxSpp = 0;
    EXPECT_EQ(adaptiveSamplingOf(r, 1 << 30).maxSpp, INT_MAX);  // 4 x spp without overflow
    r.adaptiveThreshold = 0.0;
    EXPECT_FALSE(adaptiveSamplingOf(r, 4).enabled());
}

// With adaptive sampling off every marched pixel takes spp; on, the samples go to the box's
// silhouette (a minority of the pixels, most of the error), and the image is closer to a
// 256-sample reference than uniform sampling with at least as many samples in all. And it keeps
// the image's mean: the stopping rule's bias (a pixel stops early when its first samples missed
// the box) is far under the 1% the image's mean is held to.
TEST(AdaptiveSampling, BeatsUniformSamplingAtTheSameCountAndKeepsTheMean)
{
    Scene s = boxEdgeScene();
    Scene ref = s;
    ref.render.adaptiveThreshold = 0.0;
    ref.render.spp = 256;
    ref.render.seed = 99;
    const std::vector<double> reference = beautyLuminance(render(ref));

    Scene off = s;
    off.render.adaptiveThreshold = 0.0;
    const RenderResult uniform4 = render(off);
    EXPECT_EQ(uniform4.stats.cameraSamples, 4 * uniform4.stats.marchedPixels);
    EXPECT_EQ(uniform4.stats.maxSpp, 4);

    const RenderResult adaptive = render(s);
    const double mean = double(adaptive.stats.cameraSamples) / double(adaptive.stats.marchedPixels);
    EXPECT_GT(mean, 4.5);
    EXPECT_LT(mean, 8.0) << "the extra samples go to a minority of pixels";
    EXPECT_GT(adaptive.stats.pixelsAtMostSpp, 0);
    EXPECT_EQ(adaptive.stats.maxSpp, 16);

    // Uniform sampling with at least the adaptive render's samples in all.
    Scene same = off;
    same.render.spp = int(std::ceil(mean));
    const std::vector<double> uniform = beautyLuminance(render(same));
    const std::vector<double> adapted = beautyLuminance(adaptive);
    const double eAdaptive = relMse(adapted, reference), eUniform = relMse(uniform, reference);
    std::printf("adaptive: %.2f samples per pixel, relMSE %.5f; uniform at %d: %.5f\n", mean, eAdaptive,
                same.render.spp, eUniform);
    EXPECT_LT(eAdaptive, 0.7 * eUniform) << "adaptive " << eAdaptive << ", uniform at " << same.render.spp << " spp "
                                         << eUniform;
    EXPECT_NEAR(sum(adapted) / sum(reference), 1.0, 0.01);
}
