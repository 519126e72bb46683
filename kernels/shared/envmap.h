/* envmap.h: an environment light's HDR lat-long map: direction <-> texel, and its importance
 * sampling by a 2-D piecewise-constant distribution (pbrt-v4 sec. A.5.3, "Piecewise-constant 2D
 * distributions"; the sin(theta) weighting of pbrt-v3 sec. 14.2.4). Shared by the host (the
 * sky grid of single and wkb, the tests) and the OpenCL path tracer.
 *
 * Orientation: OpenEXR's latitude-longitude convention (ImfEnvmap.h, LatLongMap), y up. The
 * image's top row looks up (+y), its bottom row down; the centre column looks along +z, the
 * column a quarter from the left along +x, a quarter from the right along -x, the left and right
 * edges along -z. With u in [0, 1) left to right and v in [0, 1] top to bottom:
 *     longitude phi = 2 pi (0.5 - u) = atan2(x, z),   latitude lambda = pi (0.5 - v),
 *     direction = (cos lambda sin phi, sin lambda, cos lambda cos phi),
 * the polar angle from +y is theta = pi v. `rotate` (radians here) turns the map about +y,
 * counter-clockwise seen from above (right-handed): the map direction seen at world direction
 * w has longitude atan2(w.x, w.z) - rotate.
 *
 * Lookups are nearest-texel: the map is the piecewise-constant function the sampler's pdf is
 * proportional to (times sin theta), so a one-texel sun is exactly a small disc of sky.
 *
 * The distribution's data, in one float array (the path tracer's buffer, the host's vector):
 *     [0, 3 W H)                          texels, RGB, row-major from the top row
 *     [3 W H, 3 W H + H + 1)              marginal CDF over rows, cdf[0] = 0, cdf[H] = 1
 *     then H runs of W + 1 floats         conditional CDF over the columns of each row
 * Texel weight f(i, j) = (R + G + B) / 3 * sin(theta_j), theta_j at the row's centre: the
 * map's pdf over (u, v) is f / mean(f) per texel, and over solid angle (dOmega = 2 pi^2
 * sin theta du dv)
 *     pdf(w) = pdf_uv(u, v) / (2 pi^2 sin theta(v)).
 */
#ifndef NIMBUS_KERNELS_SHARED_ENVMAP_H
#define NIMBUS_KERNELS_SHARED_ENVMAP_H

#include "compat.h"

/* Plain data, 16 bytes: the map's size and orientation. */
typedef struct {
    int width, height; /* texels; 0 x 0: no map */
    float rotate;      /* radians about +y */
    float pad;
} NbEnvMap;

NB_FN int nbEnvMarginalOffset(NbEnvMap m)
{
    return 3 * m.width * m.height;
}
NB_FN int nbEnvConditionalOffset(NbEnvMap m, int row)
{
    return 3 * m.width * m.height + m.height + 1 + row * (m.width + 1);
}
NB_FN int nbEnvDataSize(NbEnvMap m)
{
    return 3 * m.width * m.height + m.height + 1 + m.height * (m.width + 1);
}

/* (u, v) in [0, 1)^2 of a unit world direction. */
NB_FN void nbEnvUv(NbEnvMap m, float3 w, NB_PRIVATE float* u, NB_PRIVATE float* v)
{
    float phi = atan2(w.x, w.z) - m.rotate;
    float uu = 0.5f - phi * (0.5f / NB_PI);
    uu -= floor(uu);
    /* atan2 rather than acos(w.y): acos loses the polar angle's precision near the poles,
     * where the pdf's 1 / sin(theta) needs it. */
    float theta = atan2(sqrt(w.x * w.x + w.z * w.z), w.y);
    *u = uu;
    *v = theta * (1.0f / NB_PI);
}

/* The unit world direction at (u, v). */
NB_FN float3 nbEnvDirection(NbEnvMap m, float u, float v)
{
    float phi = 2.0f * NB_PI * (0.5f - u) + m.rotate;
    float theta = NB_PI * v;
    float s = sin(theta);
    return make_float3(s * sin(phi), cos(theta), s * cos(phi));
}

/* The texel column i and row j holding (u, v), clamped into the map. */
NB_FN int nbEnvIndex(float x, int n)
{
    int i = (int)(x * (float)n);
    return i < 0 ? 0 : (i >= n ? n - 1 : i);
}

NB_FN int nbEnvTexel(NbEnvMap m, float u, float v)
{
    return nbEnvIndex(v, m.height) * m.width + nbEnvIndex(u, m.width);
}

/* The map's value (before the light's colour) seen along unit world direction w. */
NB_FN float3 nbEnvLookup(NbEnvMap m, NB_GLOBAL const float* data, float3 w)
{
    float u, v;
    nbEnvUv(m, w, &u, &v);
    int t = 3 * nbEnvTexel(m, u, v);
    return make_float3(data[t], data[t + 1], data[t + 2]);
}

/* The last index k in [0, n) with cdf[k] <= x (cdf[0] = 0 <= x < 1 = cdf[n]). */
NB_FN int nbCdfFind(NB_GLOBAL const float* cdf, int n, float x)
{
    int lo = 0, hi = n; /* cdf[lo] <= x < cdf[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (cdf[mid] <= x)
            lo = mid;
        else
            hi = mid;
    }
    /* Zero-width intervals (texels of weight 0) never hold x: step past any that end at lo. */
    while (lo + 1 < n && !(cdf[lo + 1] > cdf[lo]))
        ++lo;
    return lo;
}

/* pdf over solid angle of direction w. */
NB_FN float nbEnvPdf(NbEnvMap m, NB_GLOBAL const float* data, float3 w)
{
    float u, v;
    nbEnvUv(m, w, &u, &v);
    int i = nbEnvIndex(u, m.width), j = nbEnvIndex(v, m.height);
    NB_GLOBAL const float* marginal = data + nbEnvMarginalOffset(m);
    NB_GLOBAL const float* cond = data + nbEnvConditionalOffset(m, j);
    float pdfUv = (marginal[j + 1] - marginal[j]) * (float)m.height * (cond[i + 1] - cond[i]) * (float)m.width;
    float s = sin(NB_PI * v);
    return s > 0.0f ? pdfUv / (2.0f * NB_PI * NB_PI * s) : 0.0f;
}

/* A direction drawn from the map's distribution; *pdf its solid-angle pdf (0: void sample). */
NB_FN float3 nbEnvSample(NbEnvMap m, NB_GLOBAL const float* data, float u0, float u1, NB_PRIVATE float* pdf)
{
    NB_GLOBAL const float* marginal = data + nbEnvMarginalOffset(m);
    int j = nbCdfFind(marginal, m.height, u1);
    float pj = marginal[j + 1] - marginal[j];
    NB_GLOBAL const float* cond = data + nbEnvConditionalOffset(m, j);
    int i = nbCdfFind(cond, m.width, u0);
    float pi = cond[i + 1] - cond[i];
    /* Uniform within the texel: the fractional position of u in the chosen interval. */
    float fu = pi > 0.0f ? clamp((u0 - cond[i]) / pi, 0.0f, 1.0f) : 0.5f;
    float fv = pj > 0.0f ? clamp((u1 - marginal[j]) / pj, 0.0f, 1.0f) : 0.5f;
    float u = ((float)i + fu) / (float)m.width, v = ((float)j + fv) / (float)m.height;
    float s = sin(NB_PI * v);
    float pdfUv = pj * (float)m.height * pi * (float)m.width;
    *pdf = s > 0.0f ? pdfUv / (2.0f * NB_PI * NB_PI * s) : 0.0f;
    return nbEnvDirection(m, u, v);
}

#endif
