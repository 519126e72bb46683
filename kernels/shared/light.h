/* light.h: light sampling for next-event estimation, shared by the single-scattering marcher
 * (area, sphere and environment lights) and the OpenCL path tracer (all lights).
 *
 * nbLightSample returns the weight W = L_i(p, wi) / pdf(wi) in W/(m^2) per unit solid-angle
 * measure, so that the single-scattered radiance toward the camera is
 *     sigma_s * phase(wo . wi) * W * T(p -> light)        (Tessendorf eq. 31, one sample)
 * For delta lights (point, spot, distant with angle 0) W is the irradiance arriving at p on a
 * surface facing the light (intensity / r^2, or the distant irradiance), the standard limit.
 * Units: distant irradiance W/m^2 (facing surface), point/spot intensity W/sr,
 * rect/sphere/environment radiance W/(m^2 sr). Skanberg sec. 6.5 covers the same cases.
 */
#ifndef NIMBUS_KERNELS_SHARED_LIGHT_H
#define NIMBUS_KERNELS_SHARED_LIGHT_H

#include "compat.h"

#define NB_LIGHT_DISTANT 0
#define NB_LIGHT_POINT 1
#define NB_LIGHT_SPOT 2
#define NB_LIGHT_RECT 3
#define NB_LIGHT_SPHERE 4
#define NB_LIGHT_ENVIRONMENT 5

/* Plain data, 20 floats + 8 ints = 112 bytes on host and device. */
typedef struct {
    float position[4];  /* point, spot, sphere: position; rect: centre */
    float direction[4]; /* distant, spot: unit direction of travel; rect: unit normal (emitting side) */
    float color[4];     /* irradiance (distant), intensity (point, spot) or radiance */
    float axisU[4];     /* rect: half-width vector; */
    float axisV[4];     /* rect: half-height vector */
    int type;
    int index; /* position in the scene's light list (per-light AOVs) */
    float p0;  /* distant: cos of half the apparent angle; spot: cos outer; sphere: radius */
    float p1;  /* spot: cos inner (full intensity inside) */
    int motion[4]; /* a light moving within the shutter (motion.h): x the offset of its knots in
                    * the path tracer's majorant buffer, y their count; 0 0: still. zw unused */
} NbLight;

typedef struct {
    float3 wi;      /* unit direction from the shading point toward the light */
    float distance; /* to the sampled point on the light; INFINITY-like 1e30 for distant/env */
    float3 weight;  /* L_i / pdf, W/m^2 (see the header comment); zero if the sample is void */
} NbLightSample;

NB_FN float nbSmoothstep(float e0, float e1, float x)
{
    if (e1 <= e0)
        return x >= e1 ? 1.0f : 0.0f;
    float t = clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

/* Uniform direction in the cone of half-angle acos(cosMax) around axis (unit). */
NB_FN float3 nbSampleCone(float3 axis, float cosMax, float u0, float u1)
{
    float c = 1.0f - u0 * (1.0f - cosMax);
    float s = sqrt(fmax(0.0f, 1.0f - c * c));
    float phi = 2.0f * NB_PI * u1;
    float3 t, b;
    nbBasis(axis, &t, &b);
    return normalize(t * (s * cos(phi)) + b * (s * sin(phi)) + axis * c);
}

NB_FN float3 nbSampleSphereUniform(float u0, float u1)
{
    float z = 1.0f - 2.0f * u0;
    float s = sqrt(fmax(0.0f, 1.0f - z * z));
    float phi = 2.0f * NB_PI * u1;
    return make_float3(s * cos(phi), s * sin(phi), z);
}

/* Spot falloff: 1 inside the inner cone, smooth to 0 at the outer cone. */
NB_FN float nbSpotFalloff(NbLight l, float3 wi)
{
    float cosAngle = -dot(wi, nbLoad3(l.direction));
    return nbSmoothstep(l.p0, l.p1, cosAngle);
}

NB_FN NbLightSample nbLightSample(NbLight l, float3 p, float u0, float u1)
{
    NbLightSample s;
    s.wi = make_float3(0.0f, 1.0f, 0.0f);
    s.distance = 1e30f;
    s.weight = make_float3(0.0f, 0.0f, 0.0f);
    float3 color = nbLoad3(l.color);
    if (l.type == NB_LIGHT_DISTANT) {
        float3 toLight = -nbLoad3(l.direction);
        if (l.p0 >= 1.0f) {
            s.wi = toLight;
            s.weight = color;
        } else {
            /* A disc of uniform radiance L subtending half-angle theta gives E = L pi sin^2(theta)
             * on a facing surface; uniform cone sampling has pdf 1 / (2 pi (1 - cos theta)). */
            float cosMax = l.p0;
            float sin2 = 1.0f - cosMax * cosMax;
            s.wi = nbSampleCone(toLight, cosMax, u0, u1);
            s.weight = color * (2.0f * (1.0f - cosMax) / sin2);
        }
    } else if (l.type == NB_LIGHT_POINT || l.type == NB_LIGHT_SPOT) {
        float3 d = nbLoad3(l.position) - p;
        float r2 = fmax(dot(d, d), 1e-12f);
        s.distance = sqrt(r2);
        s.wi = d / s.distance;
        float falloff = l.type == NB_LIGHT_SPOT ? nbSpotFalloff(l, s.wi) : 1.0f;
        s.weight = color * (falloff / r2);
    } else if (l.type == NB_LIGHT_RECT) {
        float3 q = nbLoad3(l.position) + nbLoad3(l.axisU) * (2.0f * u0 - 1.0f) + nbLoad3(l.axisV) * (2.0f * u1 - 1.0f);
        float3 d = q - p;
        float r2 = fmax(dot(d, d), 1e-12f);
        s.distance = sqrt(r2);
        s.wi = d / s.distance;
        float cosLight = -dot(s.wi, nbLoad3(l.direction));
        float area = 4.0f * length(nbLoad3(l.axisU)) * length(nbLoad3(l.axisV));
        /* Area sampling: pdf_solid = r^2 / (A cos); one-sided emitter. */
        if (cosLight > 0.0f)
            s.weight = color * (area * cosLight / r2);
    } else if (l.type == NB_LIGHT_SPHERE) {
        float3 d = nbLoad3(l.position) - p;
        float r2 = dot(d, d);
        float radius = l.p0;
        if (r2 <= radius * radius) {
            /* Inside the emitter: radiance arrives from every direction. */
            s.wi = nbSampleSphereUniform(u0, u1);
            float b = dot(s.wi, d);
            s.distance = b + sqrt(fmax(0.0f, b * b - (r2 - radius * radius)));
            s.weight = color * (4.0f * NB_PI);
        } else {
            float dist = sqrt(r2);
            float3 axis = d / dist;
            float sinMax2 = radius * radius / r2;
            float cosMax = sqrt(fmax(0.0f, 1.0f - sinMax2));
            s.wi = nbSampleCone(axis, cosMax, u0, u1);
            /* Distance to the near intersection with the sphere along wi. */
            float b = dot(s.wi, d);
            float disc = fmax(0.0f, b * b - (r2 - radius * radius));
            s.distance = b - sqrt(disc);
            s.weight = color * (2.0f * NB_PI * (1.0f - cosMax));
        }
    } else { /* environment: uniform radiance from every direction */
        s.wi = nbSampleSphereUniform(u0, u1);
        s.weight = color * (4.0f * NB_PI);
    }
    return s;
}

/* True when the light is a delta in direction (one sample is exact, no noise). */
NB_FN int nbLightIsDelta(NbLight l)
{
    return l.type == NB_LIGHT_POINT || l.type == NB_LIGHT_SPOT || (l.type == NB_LIGHT_DISTANT && l.p0 >= 1.0f);
}

#endif
