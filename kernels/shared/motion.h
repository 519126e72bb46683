/* motion.h: volume transforms and lights that move within the shutter (issue 16, item 2;
 * docs/motion-blur.md, "Transform and light motion").
 *
 * Animation keys (src/scene/Animation.h) are evaluated at the shutter's open and close and at
 * every key strictly between them: these are the knots of the motion. Between two knots the
 * animation interpolates linearly in time (transforms split as T R S: translation and scale
 * linearly, rotation by quaternion slerp along the shorter arc), so interpolating between the
 * knots reproduces the keys' interpolation exactly at every shutter time (a slerp restricted to a
 * sub-interval is the slerp between its ends). Times are seconds after the frame's time, as the
 * path's `seconds` (ptscene.h); before the first knot and after the last the value holds.
 *
 * Both layouts are runs of NB_MOTION_KNOT floats in a float buffer (the path tracer's majorant
 * buffer, whose other contents are the slot majorants):
 *  - a moving volume: first indexFromUser (3x4 row-major: the grid's index space from the space
 *    the volume's `transform` maps to world), then its knots
 *    [time, translate xyz, rotation w x y z, scale xyz, 0];
 *  - a moving light: its knots [time, position xyz, direction xyz, up xyz, 0, 0]: position is
 *    the rect light's centre, direction the rect light's normal, up the rect light's up, all as
 *    keyed (not normalised; NbLight's unit vectors are made from them as makeNbLight does).
 * Shared by the OpenCL path tracer and the host (VRL, single, wkb): one copy of the math.
 */
#ifndef NIMBUS_KERNELS_SHARED_MOTION_H
#define NIMBUS_KERNELS_SHARED_MOTION_H

#include "compat.h"
#include "light.h"

#define NB_MOTION_KNOT 12 /* floats per knot, and in a volume's leading indexFromUser */

/* The knot interval holding `seconds` among `count` knots at k (time at k[NB_MOTION_KNOT i]):
 * returns a, sets *b and the fraction *u through it (a == *b, *u = 0 outside the knots). */
NB_FN int nbMotionBracket(NB_GLOBAL const float* k, int count, float seconds, NB_PRIVATE int* b,
                          NB_PRIVATE float* u)
{
    *u = 0.0f;
    if (count < 2 || !(seconds > k[0])) {
        *b = 0;
        return 0;
    }
    if (seconds >= k[NB_MOTION_KNOT * (count - 1)]) {
        *b = count - 1;
        return count - 1;
    }
    int a = 0;
    while (a + 2 < count && seconds >= k[NB_MOTION_KNOT * (a + 1)])
        ++a;
    *b = a + 1;
    const float t0 = k[NB_MOTION_KNOT * a], t1 = k[NB_MOTION_KNOT * (a + 1)];
    *u = t1 > t0 ? (seconds - t0) / (t1 - t0) : 0.0f;
    return a;
}

/* Slerp of unit quaternions (w, x, y, z) along the shorter arc, as Animation.cpp's slerp. */
NB_FN void nbSlerp(NB_GLOBAL const float* a, NB_GLOBAL const float* bIn, float u, NB_PRIVATE float* out)
{
    float b[4] = {bIn[0], bIn[1], bIn[2], bIn[3]};
    float c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    if (c < 0.0f) {
        c = -c;
        for (int i = 0; i < 4; ++i)
            b[i] = -b[i];
    }
    float wa = 1.0f - u, wb = u;
    if (c < 1.0f - 1e-6f) {
        const float theta = acos(fmin(1.0f, c));
        const float s = sin(theta);
        wa = sin((1.0f - u) * theta) / s;
        wb = sin(u * theta) / s;
    }
    float n = 0.0f;
    for (int i = 0; i < 4; ++i) {
        out[i] = wa * a[i] + wb * b[i];
        n += out[i] * out[i];
    }
    n = 1.0f / sqrt(n);
    for (int i = 0; i < 4; ++i)
        out[i] *= n;
}

/* A moving volume's world-to-index transform at `seconds` (3x4 row-major into m): the knots'
 * T R S interpolated, inverted (p_user = S^-1 R^T (p - T)), then indexFromUser. */
NB_FN void nbMotionIndexFromWorld(NB_GLOBAL const float* block, int count, float seconds, NB_PRIVATE float* m)
{
    NB_GLOBAL const float* F = block;
    NB_GLOBAL const float* k = block + NB_MOTION_KNOT;
    int b;
    float u;
    const int a = nbMotionBracket(k, count, seconds, &b, &u);
    NB_GLOBAL const float* ka = k + NB_MOTION_KNOT * a;
    NB_GLOBAL const float* kb = k + NB_MOTION_KNOT * b;
    float t[3], s[3], q[4];
    for (int i = 0; i < 3; ++i) {
        t[i] = ka[1 + i] + (kb[1 + i] - ka[1 + i]) * u;
        s[i] = ka[8 + i] + (kb[8 + i] - ka[8 + i]) * u;
    }
    nbSlerp(ka + 4, kb + 4, u, q);
    const float w = q[0], x = q[1], y = q[2], z = q[3];
    /* R from q (Animation.cpp's matrixFromQuat); userFromWorld = S^-1 R^T, rows i = R column i / s_i. */
    float r[9];
    r[0] = 1 - 2 * (y * y + z * z), r[1] = 2 * (x * y - w * z), r[2] = 2 * (x * z + w * y);
    r[3] = 2 * (x * y + w * z), r[4] = 1 - 2 * (x * x + z * z), r[5] = 2 * (y * z - w * x);
    r[6] = 2 * (x * z - w * y), r[7] = 2 * (y * z + w * x), r[8] = 1 - 2 * (x * x + y * y);
    float uw[12];
    for (int i = 0; i < 3; ++i) {
        const float inv = 1.0f / s[i];
        uw[4 * i + 0] = r[0 + i] * inv;
        uw[4 * i + 1] = r[3 + i] * inv;
        uw[4 * i + 2] = r[6 + i] * inv;
        uw[4 * i + 3] = -(uw[4 * i + 0] * t[0] + uw[4 * i + 1] * t[1] + uw[4 * i + 2] * t[2]);
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 4; ++j)
            m[4 * i + j] = F[4 * i + 0] * uw[j] + F[4 * i + 1] * uw[4 + j] + F[4 * i + 2] * uw[8 + j];
        m[4 * i + 3] += F[4 * i + 3];
    }
}

/* Light l (as makeNbLight made it at the frame) placed at `seconds` by its knots. */
NB_FN NbLight nbLightAt(NbLight l, NB_GLOBAL const float* k, int count, float seconds)
{
    int b;
    float u;
    const int a = nbMotionBracket(k, count, seconds, &b, &u);
    NB_GLOBAL const float* ka = k + NB_MOTION_KNOT * a;
    NB_GLOBAL const float* kb = k + NB_MOTION_KNOT * b;
    float3 v[3];
    for (int j = 0; j < 3; ++j)
        v[j] = make_float3(ka[1 + 3 * j] + (kb[1 + 3 * j] - ka[1 + 3 * j]) * u,
                           ka[2 + 3 * j] + (kb[2 + 3 * j] - ka[2 + 3 * j]) * u,
                           ka[3 + 3 * j] + (kb[3 + 3 * j] - ka[3 + 3 * j]) * u);
    l.position[0] = v[0].x, l.position[1] = v[0].y, l.position[2] = v[0].z;
    if (l.type == NB_LIGHT_DISTANT || l.type == NB_LIGHT_SPOT || l.type == NB_LIGHT_RECT) {
        const float3 n = normalize(v[1]);
        l.direction[0] = n.x, l.direction[1] = n.y, l.direction[2] = n.z;
    }
    if (l.type == NB_LIGHT_RECT) { /* the frame as makeNbLight builds it, half sizes kept */
        const float3 n = make_float3(l.direction[0], l.direction[1], l.direction[2]);
        const float hu = length(make_float3(l.axisU[0], l.axisU[1], l.axisU[2]));
        const float hv = length(make_float3(l.axisV[0], l.axisV[1], l.axisV[2]));
        const float3 vv = normalize(v[2] - n * dot(v[2], n));
        const float3 uu = cross(vv, n) * hu;
        l.axisU[0] = uu.x, l.axisU[1] = uu.y, l.axisU[2] = uu.z;
        l.axisV[0] = vv.x * hv, l.axisV[1] = vv.y * hv, l.axisV[2] = vv.z * hv;
    }
    return l;
}

#endif
