// The skin cells' one-point estimator (src/vrl/SkinCells.h, SkinPoint): over a stretch of
// piecewise-constant chromatic extinction, the mean of draw()'s estimate times a camera
// transmittance at the drawn point must be int sigma_s T T_cam dt, computed here in closed form
// (each step's integral of a product of exponentials), within four standard errors; and the same
// check must fail for the estimate without its pdf's in-step factor (the point drawn uniformly
// but divided as if drawn by sigma_s T).
#include "vrl/SkinCells.h"

#include "../../kernels/shared/rng.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace nimbus::vrl {
namespace {

struct Step {
    float dt;
    Rgb sigmaS, sigmaT;
};

// T_cam along the stretch: e^{-k t}, per channel (a camera on the far side of a slab).
const float kCam[3] = {3.0f, 5.0f, 0.5f};

// int_0^L sigma_s T(t) e^{-k t} dt per channel, T the stretch's own transmittance from t = 0.
void exact(const std::vector<Step>& steps, double out[3])
{
    for (int c = 0; c < 3; ++c) {
        double t = 0.0, tau = 0.0, sum = 0.0;
        for (const Step& s : steps) {
            const double st = (&s.sigmaT.x)[c], ss = (&s.sigmaS.x)[c], a = st + kCam[c];
            // int_0^dt ss e^{-tau - st u} e^{-k (t + u)} du
            sum += ss * std::exp(-tau - kCam[c] * t) * -std::expm1(-a * s.dt) / a;
            tau += st * s.dt;
            t += s.dt;
        }
        out[c] = sum;
    }
}

// The mean and standard error of the estimator over n stretches.
void estimate(const std::vector<Step>& steps, int n, bool uniformInStep, double mean[3], double se[3])
{
    double s1[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
    NbRng rng = nbRngStart(7, 1, 2);
    const float3 o = make_float3(0, 0, 0), d = make_float3(1, 0, 0);
    for (int i = 0; i < n; ++i) {
        SkinPoint p;
        float T[3] = {1, 1, 1}, t0 = 0.0f;
        for (const Step& s : steps) {
            p.offer(t0, s.dt, T, s.sigmaS, s.sigmaT, nbRngNext(&rng));
            for (int c = 0; c < 3; ++c)
                T[c] *= std::exp(-(&s.sigmaT.x)[c] * s.dt);
            t0 += s.dt;
        }
        float e[3];
        float3 x = p.draw(o, d, nbRngNext(&rng), e);
        if (uniformInStep) {
            // Move the point uniformly within its step (keeping the estimate's division): biased.
            float t = 0.0f;
            for (const Step& s : steps) {
                if (x.x <= t + s.dt) {
                    x.x = t + nbRngNext(&rng) * s.dt;
                    break;
                }
                t += s.dt;
            }
        }
        for (int c = 0; c < 3; ++c) {
            const double v = double(e[c]) * std::exp(-double(kCam[c]) * double(x.x));
            s1[c] += v;
            s2[c] += v * v;
        }
    }
    for (int c = 0; c < 3; ++c) {
        mean[c] = s1[c] / n;
        se[c] = std::sqrt(std::max(0.0, s2[c] / n - mean[c] * mean[c]) / n);
    }
}

const std::vector<Step> kStretch = {
    {0.4f, make_float3(2.0f, 1.5f, 0.8f), make_float3(2.5f, 2.0f, 1.0f)},
    {0.3f, make_float3(8.0f, 6.0f, 3.0f), make_float3(9.0f, 7.0f, 4.0f)},  // thick: several optical depths
    {0.5f, make_float3(0.0f, 0.0f, 0.0f), make_float3(0.0f, 0.0f, 0.0f)},  // empty
    {0.2f, make_float3(1.0f, 2.0f, 3.0f), make_float3(1.2f, 2.2f, 3.3f)},
};

TEST(SkinPoint, EstimatesTheCameraWeightedIntegralWithoutBias)
{
    double want[3], mean[3], se[3];
    exact(kStretch, want);
    estimate(kStretch, 400000, false, mean, se);
    for (int c = 0; c < 3; ++c) {
        std::printf("channel %d: exact %.6f, estimate %.6f +- %.6f (z %+.2f)\n", c, want[c], mean[c], se[c],
                    (mean[c] - want[c]) / se[c]);
        EXPECT_NEAR(mean[c], want[c], 4.0 * se[c]);
    }
}

TEST(SkinPoint, TheSameCheckCatchesAPointNotDrawnByItsPdf)
{
    double want[3], mean[3], se[3];
    exact(kStretch, want);
    estimate(kStretch, 400000, true, mean, se);
    int off = 0;
    for (int c = 0; c < 3; ++c)
        off += std::fabs(mean[c] - want[c]) > 4.0 * se[c];
    EXPECT_GT(off, 0);
}

}  // namespace
}  // namespace nimbus::vrl
