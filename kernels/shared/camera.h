/* camera.h: the perspective pinhole camera with linear motion over the shutter, shared by the
 * host integrators and the OpenCL path tracer so both generate identical primary rays.
 *
 * Image plane: pixel (0,0) is the top-left; x right, y down. The vertical field of view is
 * `fov`; the basis is right-handed with y up (DESIGN "Units and conventions").
 * Motion blur (Tessendorf sec. 7, eq. 90): each pixel sample draws a time in the shutter and the
 * camera frame is interpolated linearly between open and close, and an animated fov (a zoom)
 * between its knots within the shutter, as its keys interpolate it: linearly in degrees between
 * the values at the shutter's open, every key inside it and its close (docs/motion-blur.md).
 */
#ifndef NIMBUS_KERNELS_SHARED_CAMERA_H
#define NIMBUS_KERNELS_SHARED_CAMERA_H

#include "compat.h"

/* The most fov knots within one shutter: its open, its close and up to 6 keys between them
 * (evaluateAnimation refuses more). */
#define NB_CAMERA_FOV_KNOTS 8

/* Plain data with fixed-width members (STYLE rule 3): (3 * 4 * 2 + 4 + 2 * 8) floats = 176 bytes. */
typedef struct {
    float originOpen[4];  /* xyz, w unused */
    float forwardOpen[4]; /* unit view direction */
    float rightOpen[4];   /* unit, scaled by tanHalfFov * aspect in w */
    float originClose[4];
    float forwardClose[4];
    float rightClose[4];
    float tanHalfFov; /* tan(fov/2), vertical */
    float aspect;     /* width / height */
    float hasMotion;  /* 0 or 1 */
    float fovKnots;   /* 0: the fov holds still (tanHalfFov); else 2..NB_CAMERA_FOV_KNOTS knots */
    float fovTime[NB_CAMERA_FOV_KNOTS]; /* the knots' times, fractions of the shutter, increasing
                                         * from 0 (open) to 1 (close) */
    float fovHalf[NB_CAMERA_FOV_KNOTS]; /* half the vertical fov at each knot, radians */
} NbCamera;

/* tan(fov/2) at shutter time fraction t in [0,1]: the fov interpolated linearly between the
 * knots around t (the keys' own interpolation, in angle), so a zoom's rays sweep as the
 * animation says, not linearly in the image plane. */
NB_FN float nbCameraTanHalfFov(NbCamera cam, float t)
{
    if (cam.fovKnots < 1.5f)
        return cam.tanHalfFov;
    const int n = (int)cam.fovKnots;
    int i = 0;
    while (i + 2 < n && t > cam.fovTime[i + 1])
        ++i;
    const float a = cam.fovTime[i], b = cam.fovTime[i + 1];
    const float u = b > a ? clamp((t - a) / (b - a), 0.0f, 1.0f) : 0.0f;
    return tan(cam.fovHalf[i] + (cam.fovHalf[i + 1] - cam.fovHalf[i]) * u);
}

/* Primary ray through image-plane position (x, y) in pixels (fractional, sample jitter
 * included) at shutter time fraction t in [0,1]. Writes origin and unit direction. */
NB_FN void nbCameraRay(NbCamera cam, float x, float y, int width, int height, float t, NB_PRIVATE float3* origin,
                       NB_PRIVATE float3* dir)
{
    float3 o = nbLoad3(cam.originOpen);
    float3 f = nbLoad3(cam.forwardOpen);
    float3 r = nbLoad3(cam.rightOpen);
    if (cam.hasMotion > 0.5f) {
        o = o + (nbLoad3(cam.originClose) - o) * t;
        f = normalize(f + (nbLoad3(cam.forwardClose) - f) * t);
        r = normalize(r + (nbLoad3(cam.rightClose) - r) * t);
        r = normalize(r - f * dot(r, f));
    }
    float3 u = cross(r, f);
    const float tanHalfFov = nbCameraTanHalfFov(cam, t);
    float sx = (2.0f * x / (float)width - 1.0f) * tanHalfFov * cam.aspect;
    float sy = (1.0f - 2.0f * y / (float)height) * tanHalfFov;
    *origin = o;
    *dir = normalize(f + r * sx + u * sy);
}

/* The view axis at shutter time t: the direction depth maps measure along (holdoutdepth.h). */
NB_FN float3 nbCameraViewAxis(NbCamera cam, float t)
{
    float3 f = nbLoad3(cam.forwardOpen);
    if (cam.hasMotion > 0.5f)
        f = normalize(f + (nbLoad3(cam.forwardClose) - f) * t);
    return f;
}

#endif
