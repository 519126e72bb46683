/* equiangular.h: equi-angular sampling of a distance along a ray towards a point (Kulla and
 * Fajardo 2012, "Importance sampling techniques for path tracing in participating media",
 * sec. 4.1; Oppitz 2018 eqs. 7.7-7.8), and the MIS weight that combines it with the path
 * tracer's distance sampling (pathtrace.cl; the estimator and its proof are in
 * docs/pathtracer.md, "Equi-angular sampling towards point and spot lights").
 *
 * Geometry: the ray o + t d (world space, metres, d unit) over t in [a, b], and the point c (a
 * point or spot light's position). Delta = dot(c - o, d) is the ray parameter of the foot of the
 * perpendicular from c, h the distance from c to the ray's line. With t - Delta = h tan(theta)
 * the inverse-square factor becomes uniform in the angle: 1 / (h^2 + (t - Delta)^2) dt =
 * dtheta / h. Sampling theta uniformly over [theta_a, theta_b] (theta_x = atan((x - Delta) / h))
 * gives
 *     t = Delta + h tan(theta),      pdf(t) = h / ((theta_b - theta_a) (h^2 + (t - Delta)^2))
 * (Kulla and Fajardo eqs. 6-7; Oppitz eq. 7.8), so sigma_s I / r^2 / pdf is bounded along the
 * segment by sigma_s I (theta_b - theta_a) / h: no firefly near the light.
 *
 * A ray through the light itself (h -> 0) makes the integrand non-integrable (the camera sees a
 * delta). h is floored at kEquiMinH times the segment's length, the same h in the sampling and
 * in the pdf: still an exact pdf of what is sampled, so the estimator stays unbiased for every
 * ray whose integral is finite.
 */
#ifndef NIMBUS_KERNELS_SHARED_EQUIANGULAR_H
#define NIMBUS_KERNELS_SHARED_EQUIANGULAR_H

#include "compat.h"

#define NB_EQUI_MIN_H 1e-5f

typedef struct {
    float a, b;           /* the segment, ray parameters (metres), a < b */
    float delta;          /* ray parameter of the foot of the perpendicular from the point */
    float h;              /* distance from the point to the line (floored), metres */
    float thetaA, thetaB; /* angles of a and b seen from the point, radians, in (-pi/2, pi/2) */
} NbEquiAngular;

/* The distribution over [a, b] of the ray o + t d (d unit) towards the point c. */
NB_FN NbEquiAngular nbEquiInit(float3 o, float3 d, float3 c, float a, float b)
{
    NbEquiAngular e;
    const float3 oc = c - o;
    e.a = a;
    e.b = b;
    e.delta = dot(oc, d);
    const float3 perp = oc - d * e.delta;
    e.h = fmax(sqrt(dot(perp, perp)), NB_EQUI_MIN_H * fmax(b - a, 1e-6f));
    e.thetaA = atan((a - e.delta) / e.h);
    e.thetaB = atan((b - e.delta) / e.h);
    return e;
}

/* The pdf (1/m) of t; 0 outside [a, b]. */
NB_FN float nbEquiPdf(NbEquiAngular e, float t)
{
    if (!(t >= e.a && t <= e.b))
        return 0.0f;
    const float x = t - e.delta;
    const float span = e.thetaB - e.thetaA;
    if (!(span > 0.0f))
        return 0.0f;
    return e.h / (span * (e.h * e.h + x * x));
}

/* t from one uniform number u in [0, 1) by the inverse cdf; clamped to [a, b] against the
 * rounding of tan near +-pi/2. */
NB_FN float nbEquiSample(NbEquiAngular e, float u)
{
    const float theta = e.thetaA + u * (e.thetaB - e.thetaA);
    const float t = e.delta + e.h * tan(theta);
    return fmin(fmax(t, e.a), e.b);
}

/* Whether equi-angular sampling is worth its two ratio-tracking walks on this segment: its pdf's
 * peak (at the point of the segment nearest the foot) reaches NB_EQUI_MIN_PEAK times muMax, the
 * largest majorant along the segment, which bounds the distance sampling's pdf. Below that the
 * distance sampling's NEE is not firefly-bound (its relative variance per sample along a ray at
 * distance h from the light grows like 1 / (sigma_t h) only for sigma_t h < 1) and equi-angular
 * would take a small weight anyway. The decision is a deterministic function of the segment,
 * made identically for both techniques, so the weights still sum to 1 (docs/pathtracer.md). */
#define NB_EQUI_MIN_PEAK 0.5f

NB_FN int nbEquiWorthwhile(NbEquiAngular e, float muMax)
{
    return nbEquiPdf(e, fmin(fmax(e.delta, e.a), e.b)) >= NB_EQUI_MIN_PEAK * muMax;
}

/* An upper bound on that peak without the two atans, so that flights far from every light pay
 * almost nothing: dtheta/dt = h / (h^2 + x^2) >= h / Dmax^2 on the segment, so
 * theta_b - theta_a >= (b - a) h / Dmax^2 and the peak h / ((theta_b - theta_a) Dmin^2) <=
 * Dmax^2 / ((b - a) Dmin^2), Dmin and Dmax the nearest and farthest distances from the point c
 * to the segment (h floored as in nbEquiInit). */
NB_FN float nbEquiPeakBound(float3 o, float3 d, float3 c, float a, float b)
{
    const float3 oc = c - o;
    const float delta = dot(oc, d);
    const float3 perp = oc - d * delta;
    const float h = fmax(sqrt(dot(perp, perp)), NB_EQUI_MIN_H * fmax(b - a, 1e-6f));
    const float xa = a - delta, xb = b - delta;
    const float xn = xa > 0.0f ? xa : (xb < 0.0f ? xb : 0.0f);
    const float dmin2 = h * h + xn * xn, dmax2 = h * h + fmax(xa * xa, xb * xb);
    return dmax2 / (fmax(b - a, 1e-30f) * dmin2);
}

/* The power-heuristic weight (Veach 1997 sec. 9.2, beta = 2) of the equi-angular technique at a
 * point where it has pdf pEqui and the distance sampling has (proxy) pdf pTrack. The distance
 * sampling's weight at the same point is exactly 1 minus this, so the two sum to 1 everywhere:
 * 1 where pTrack = 0 (the tracking cannot sample there), 0 where pEqui = 0 (outside [a, b]). */
NB_FN float nbEquiMisWeight(float pEqui, float pTrack)
{
    if (!(pEqui > 0.0f))
        return 0.0f;
    const float r = pTrack / pEqui;
    return 1.0f / (1.0f + r * r);
}

#endif
