/* filter.h: pixel reconstruction filters, applied by filter importance sampling (Ernst, Stamminger
 * and Greiner 2006; pbrt-v4 sec. 8.8.3): each camera sample's offset from its pixel's centre is
 * drawn from the filter itself, so every sample weighs exactly 1 and a pixel's mean is an
 * unbiased estimate of the filtered image for filters that are never negative (all three here).
 * Shared by the host's tile driver and the OpenCL path tracer, so every integrator filters alike.
 *
 * Separable: the x and y offsets are drawn independently from one 1-D profile f(x) on
 * |x| <= r = width / 2 (pixels), normalised to integrate to 1.
 *   box              f = 1 / width                 (width 1: one sample area per pixel)
 *   gaussian         f ~ exp(-x^2 / (2 s^2)), s = width / 4, cut at 2 s (the scene's default,
 *                    width 2: s = 0.5 pixel, pbrt-v4's default standard deviation)
 *   blackman_harris  the 4-term Blackman-Harris window over [-r, r] (Harris 1978: a0..a3 below;
 *                    Arnold uses width 3)
 * render.filter_width defaults to 2 for every filter (docs/scene-format.md).
 * Sampling inverts the profile's CDF: the Gaussian's in closed form (the inverse error function,
 * Giles 2010), the Blackman-Harris window's by Newton steps kept inside a shrinking bracket
 * (bisection where a step leaves it), which reach float resolution within 12 steps for every u.
 */
#ifndef NIMBUS_KERNELS_SHARED_FILTER_H
#define NIMBUS_KERNELS_SHARED_FILTER_H

#include "compat.h"

#define NB_FILTER_BOX 0
#define NB_FILTER_GAUSSIAN 1
#define NB_FILTER_BLACKMAN_HARRIS 2

#define NB_BH_A0 0.35875f
#define NB_BH_A1 0.48829f
#define NB_BH_A2 0.14128f
#define NB_BH_A3 0.01168f

/* The normalised 1-D profile at offset x (pixels): integrates to 1 over [-width/2, width/2]. */
NB_FN float nbFilterEval(int type, float width, float x)
{
    float r = 0.5f * width;
    if (!(fabs(x) <= r))
        return 0.0f;
    if (type == NB_FILTER_GAUSSIAN) {
        float s = 0.25f * width;
        /* int_{-2s}^{2s} exp(-x^2/2s^2) dx = s sqrt(2 pi) erf(sqrt 2) */
        return exp(-0.5f * (x / s) * (x / s)) / (s * 2.5066283f * erf(1.4142136f));
    }
    if (type == NB_FILTER_BLACKMAN_HARRIS) {
        float t = x / width + 0.5f; /* in [0, 1] */
        float w = NB_BH_A0 - NB_BH_A1 * cos(2.0f * NB_PI * t) + NB_BH_A2 * cos(4.0f * NB_PI * t) -
                  NB_BH_A3 * cos(6.0f * NB_PI * t);
        return w / (NB_BH_A0 * width);
    }
    return 1.0f / width;
}

/* Its CDF from -width/2 to x. */
NB_FN float nbFilterCdf(int type, float width, float x)
{
    float r = 0.5f * width;
    if (x <= -r)
        return 0.0f;
    if (x >= r)
        return 1.0f;
    if (type == NB_FILTER_GAUSSIAN) {
        float s = 0.25f * width;
        return 0.5f + 0.5f * erf(x / (s * 1.4142136f)) / erf(1.4142136f);
    }
    if (type == NB_FILTER_BLACKMAN_HARRIS) {
        float t = x / width + 0.5f;
        float a = NB_BH_A0 * t - NB_BH_A1 * sin(2.0f * NB_PI * t) / (2.0f * NB_PI) +
                  NB_BH_A2 * sin(4.0f * NB_PI * t) / (4.0f * NB_PI) - NB_BH_A3 * sin(6.0f * NB_PI * t) / (6.0f * NB_PI);
        return a / NB_BH_A0;
    }
    return x / width + 0.5f;
}

/* erf^-1(x) for |x| <= 0.993 (w < 5): Giles 2010, "Approximating the erfinv function" (GPU Computing
 * Gems), single-precision central branch; absolute error 3.5e-7 over |x| <= erf(sqrt 2), the range
 * the Gaussian filter uses (tests/core/test_filter.cpp holds it against Boost.Math). */
NB_FN float nbErfInvCentral(float x)
{
    float w = -log((1.0f - x) * (1.0f + x)) - 2.5f;
    float p = 2.81022636e-08f;
    p = 3.43273939e-07f + p * w;
    p = -3.5233877e-06f + p * w;
    p = -4.39150654e-06f + p * w;
    p = 0.00021858087f + p * w;
    p = -0.00125372503f + p * w;
    p = -0.00417768164f + p * w;
    p = 0.246640727f + p * w;
    p = 1.50140941f + p * w;
    return p * x;
}

/* An offset in pixels from the pixel's centre, distributed as the profile, for u in [0, 1). */
NB_FN float nbFilterSample(int type, float width, float u)
{
    float r = 0.5f * width;
    if (type == NB_FILTER_GAUSSIAN) {
        /* CDF(x) = 1/2 + erf(x / (s sqrt 2)) / (2 erf(sqrt 2)), so x = s sqrt 2 erf^-1((2u - 1) erf(sqrt 2)). */
        float s = 0.25f * width;
        return clamp(s * 1.4142136f * nbErfInvCentral((2.0f * u - 1.0f) * 0.95449974f), -r, r);
    }
    if (type != NB_FILTER_BLACKMAN_HARRIS)
        return (u - 0.5f) * width;
    float lo = -r, hi = r, x = (u - 0.5f) * r; /* the profiles are narrower than the box */
    for (int i = 0; i < 12; ++i) {
        float f = nbFilterCdf(type, width, x) - u;
        if (f == 0.0f)
            break;
        if (f > 0.0f)
            hi = x;
        else
            lo = x;
        float p = nbFilterEval(type, width, x);
        float next = p > 0.0f ? x - f / p : 0.5f * (lo + hi);
        x = (next >= lo && next <= hi) ? next : 0.5f * (lo + hi);
    }
    return clamp(x, -r, r);
}

#endif
