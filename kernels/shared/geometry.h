/* geometry.h: the scene's geometry (docs/geometry.md) as the OpenCL path tracer reads it: a
 * binary BVH flattened into an array of nodes, its primitives, and the two traversals (the
 * closest hit for camera rays and path segments, any hit for shadow rays).
 *
 * The host builds the tree with Embree's BVH builder (rtcBuildBVH, binned SAH) through its own
 * node callbacks and flattens it depth first (src/geometry/KernelBvh.cpp); the layouts below are
 * static_asserted there, offsets included, so host and device agree byte for byte. The same
 * traversal compiles for the host (compat.h), which is how the tests compare it with Embree's
 * rtcIntersect1 ray for ray.
 *
 * Primitives carry their object's flags: NB_GEOM_HOLDOUT (camera rays stop at it) and
 * NB_GEOM_SHADOWS (it blocks light). One tree holds every object; a query names the flag it
 * wants and skips the primitives without it (their boxes still cost a visit, a small price for
 * not keeping two trees when most scenes have objects that are both).
 *
 * Triangles use the watertight test of Woop, Benthin and Wald 2013 ("Watertight ray/triangle
 * intersection", JCGT 2(1)): no ray slips between two triangles that share an edge, as with
 * Embree's robust scenes that the CPU integrators use. Spheres are the exact quadric under the
 * object's transform (GeometrySet.h); infinite planes, which no box bounds, sit after the
 * tree's primitives and are tested after the traversal. Boxes are tested with the far distance
 * scaled by 1 + 2 gamma_3 (Ize 2013, "Robust BVH ray traversal", JCGT 2(2)), so rounding never
 * culls a box that the ray touches.
 */
#ifndef NIMBUS_KERNELS_SHARED_GEOMETRY_H
#define NIMBUS_KERNELS_SHARED_GEOMETRY_H

#include "compat.h"

#define NB_GEOM_HOLDOUT 1u /* the object is a holdout: camera rays stop at it */
#define NB_GEOM_SHADOWS 2u /* the object is a shadow caster: light and paths stop at it */

#define NB_PRIM_TRIANGLE 0u
#define NB_PRIM_SPHERE 1u
#define NB_PRIM_PLANE 2u /* infinite: after the tree's primitives, never in a leaf */

/* Deepest tree the host builds (Embree's maxDepth); the traversal stack holds one entry per
 * level. */
#define NB_BVH_MAX_DEPTH 48

#define NB_GEOM_MISS INFINITY

/* A node of the flattened tree, 32 bytes: its world-space box and either two children (count 0;
 * the first child is the next node, depth first, the second at `offset`) or a leaf of `count`
 * primitives from index `offset`. */
typedef struct {
    float lo[3];
    nb_uint offset;
    float hi[3];
    nb_uint count;
} NbBvhNode;

/* A primitive, 64 bytes. data: a triangle's vertices v0, v1, v2 (xyz each, world space; 3
 * floats unused); a sphere's objectFromWorld, 3x4 row major (the sphere is
 * |objectFromWorld x| = radius); an infinite plane's point and unit normal (xyz each). */
typedef struct {
    float data[12];
    float radius;
    nb_uint type;   /* NB_PRIM_* */
    nb_uint flags;  /* NB_GEOM_HOLDOUT | NB_GEOM_SHADOWS: the object's */
    nb_uint object; /* index of the object in the scene's geometry list */
} NbGeomPrim;

/* Where the tree and the planes are. */
typedef struct {
    int nodeCount;  /* 0: no tree (only infinite planes, or nothing) */
    int planeFirst; /* the infinite planes are prims[planeFirst, planeFirst + planeCount) */
    int planeCount;
    int pad;
} NbGeomScene;

NB_FN float nbGeomAxis(float3 v, int axis)
{
    return axis == 0 ? v.x : (axis == 1 ? v.y : v.z);
}

/* The per-ray constants of the watertight test: the axis where |d| is largest becomes z, the
 * other two are sheared so the ray runs along +z. */
typedef struct {
    int kx, ky, kz;
    float Sx, Sy, Sz;
    float3 invD; /* 1 / d for the box tests, zero components replaced by tiny ones */
} NbGeomRay;

NB_FN NbGeomRay nbGeomRaySetup(float3 d)
{
    NbGeomRay r;
    const float ax = fabs(d.x), ay = fabs(d.y), az = fabs(d.z);
    r.kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
    r.kx = r.kz == 2 ? 0 : r.kz + 1;
    r.ky = r.kx == 2 ? 0 : r.kx + 1;
    const float dz = nbGeomAxis(d, r.kz);
    if (dz < 0.0f) { /* keep the winding: swap x and y */
        int k = r.kx;
        r.kx = r.ky;
        r.ky = k;
    }
    r.Sx = nbGeomAxis(d, r.kx) / dz;
    r.Sy = nbGeomAxis(d, r.ky) / dz;
    r.Sz = 1.0f / dz;
    /* A zero component would make 0 * inf = NaN where the origin lies on a slab's plane. */
    const float tiny = 1e-30f;
    float3 dd = make_float3(ax > tiny ? d.x : (d.x < 0.0f ? -tiny : tiny), ay > tiny ? d.y : (d.y < 0.0f ? -tiny : tiny),
                            az > tiny ? d.z : (d.z < 0.0f ? -tiny : tiny));
    r.invD = make_float3(1.0f / dd.x, 1.0f / dd.y, 1.0f / dd.z);
    return r;
}

/* Woop et al. 2013, fig. 4 (without the double-precision fallback for exactly zero edge
 * functions: a zero counts as inside, so a ray through a shared edge hits both triangles, never
 * neither). The t of the hit in (tNear, tFar), else INFINITY. */
NB_FN float nbIntersectTriangle(const NB_GLOBAL NbGeomPrim* p, float3 o, NB_PRIVATE const NbGeomRay* r, float tNear,
                                float tFar)
{
    const float3 A = make_float3(p->data[0], p->data[1], p->data[2]) - o;
    const float3 B = make_float3(p->data[3], p->data[4], p->data[5]) - o;
    const float3 C = make_float3(p->data[6], p->data[7], p->data[8]) - o;
    const float Az = nbGeomAxis(A, r->kz), Bz = nbGeomAxis(B, r->kz), Cz = nbGeomAxis(C, r->kz);
    const float Ax = nbGeomAxis(A, r->kx) - r->Sx * Az, Ay = nbGeomAxis(A, r->ky) - r->Sy * Az;
    const float Bx = nbGeomAxis(B, r->kx) - r->Sx * Bz, By = nbGeomAxis(B, r->ky) - r->Sy * Bz;
    const float Cx = nbGeomAxis(C, r->kx) - r->Sx * Cz, Cy = nbGeomAxis(C, r->ky) - r->Sy * Cz;
    const float U = Cx * By - Cy * Bx, V = Ax * Cy - Ay * Cx, W = Bx * Ay - By * Ax;
    if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f))
        return NB_GEOM_MISS;
    const float det = U + V + W;
    if (det == 0.0f)
        return NB_GEOM_MISS; /* the ray lies in the triangle's plane */
    const float T = r->Sz * (U * Az + V * Bz + W * Cz);
    const float t = T / det;
    return t > tNear && t < tFar ? t : NB_GEOM_MISS;
}

/* The sphere |M x| = radius, M = objectFromWorld: with p = M o and v = M d, the roots of
 * |p + t v|^2 = r^2 as tMid -+ sqrt((r^2 - |q|^2) / |v|^2), q = p + tMid v the point nearest the
 * centre, which keeps its digits in float where b^2 - ac would cancel (GeometrySet.cpp's
 * intersectSphere, the host's double version). */
NB_FN float nbIntersectSphere(const NB_GLOBAL NbGeomPrim* s, float3 o, float3 d, float tNear, float tFar)
{
    const NB_GLOBAL float* m = s->data;
    const float3 p = make_float3(m[0] * o.x + m[1] * o.y + m[2] * o.z + m[3], m[4] * o.x + m[5] * o.y + m[6] * o.z + m[7],
                                 m[8] * o.x + m[9] * o.y + m[10] * o.z + m[11]);
    const float3 v =
        make_float3(m[0] * d.x + m[1] * d.y + m[2] * d.z, m[4] * d.x + m[5] * d.y + m[6] * d.z, m[8] * d.x + m[9] * d.y + m[10] * d.z);
    const float a = dot(v, v);
    if (!(a > 0.0f))
        return NB_GEOM_MISS;
    const float tMid = -dot(p, v) / a;
    const float3 q = p + v * tMid;
    const float rest = s->radius * s->radius - dot(q, q);
    if (rest < 0.0f)
        return NB_GEOM_MISS;
    const float halfChord = sqrt(rest / a);
    const float t0 = tMid - halfChord, t1 = tMid + halfChord;
    if (t0 > tNear && t0 < tFar)
        return t0;
    if (t1 > tNear && t1 < tFar)
        return t1;
    return NB_GEOM_MISS;
}

NB_FN float nbIntersectPlane(const NB_GLOBAL NbGeomPrim* pl, float3 o, float3 d, float tNear, float tFar)
{
    const float3 n = make_float3(pl->data[3], pl->data[4], pl->data[5]);
    const float dn = dot(d, n);
    if (dn == 0.0f)
        return NB_GEOM_MISS;
    const float t = dot(make_float3(pl->data[0], pl->data[1], pl->data[2]) - o, n) / dn;
    return t > tNear && t < tFar ? t : NB_GEOM_MISS;
}

NB_FN float nbIntersectPrim(const NB_GLOBAL NbGeomPrim* p, float3 o, float3 d, NB_PRIVATE const NbGeomRay* r, float tNear,
                            float tFar)
{
    if (p->type == NB_PRIM_TRIANGLE)
        return nbIntersectTriangle(p, o, r, tNear, tFar);
    if (p->type == NB_PRIM_SPHERE)
        return nbIntersectSphere(p, o, d, tNear, tFar);
    return nbIntersectPlane(p, o, d, tNear, tFar);
}

/* The entry distance of o + t d into the node's box within [tNear, tFar], else INFINITY. */
NB_FN float nbBoxEntry(const NB_GLOBAL NbBvhNode* n, float3 o, NB_PRIVATE const NbGeomRay* r, float tNear, float tFar)
{
    const float tx0 = (n->lo[0] - o.x) * r->invD.x, tx1 = (n->hi[0] - o.x) * r->invD.x;
    const float ty0 = (n->lo[1] - o.y) * r->invD.y, ty1 = (n->hi[1] - o.y) * r->invD.y;
    const float tz0 = (n->lo[2] - o.z) * r->invD.z, tz1 = (n->hi[2] - o.z) * r->invD.z;
    float t0 = tNear, t1 = tFar;
    t0 = fmax(t0, fmin(tx0, tx1));
    t0 = fmax(t0, fmin(ty0, ty1));
    t0 = fmax(t0, fmin(tz0, tz1));
    t1 = fmin(t1, fmax(tx0, tx1) * 1.0000008f);
    t1 = fmin(t1, fmax(ty0, ty1) * 1.0000008f);
    t1 = fmin(t1, fmax(tz0, tz1) * 1.0000008f);
    return t0 <= t1 ? t0 : NB_GEOM_MISS;
}

/* The first surface with `flag` along o + t d, t in (tNear, tFar) (d any length, t in its units),
 * or INFINITY. anyHit: return at the first surface found, not the nearest (shadow rays). */
NB_FN float nbGeomTrace(const NB_GLOBAL NbBvhNode* nodes, const NB_GLOBAL NbGeomPrim* prims, NbGeomScene g, float3 o,
                        float3 d, float tNear, float tFar, nb_uint flag, int anyHit)
{
    const NbGeomRay r = nbGeomRaySetup(d);
    float tHit = tFar;
    int found = 0;
    for (int i = 0; i < g.planeCount; ++i) {
        const NB_GLOBAL NbGeomPrim* p = prims + g.planeFirst + i;
        if (!(p->flags & flag))
            continue;
        const float t = nbIntersectPlane(p, o, d, tNear, tHit);
        if (t < tHit) {
            tHit = t;
            found = 1;
            if (anyHit)
                return tHit;
        }
    }
    if (g.nodeCount > 0 && nbBoxEntry(nodes, o, &r, tNear, tHit) < NB_GEOM_MISS) {
        /* Nodes still to visit and the distance where the ray enters each. */
        nb_uint stack[NB_BVH_MAX_DEPTH + 1];
        float stackT[NB_BVH_MAX_DEPTH + 1];
        int top = 0;
        nb_uint node = 0;
        for (;;) {
            const NB_GLOBAL NbBvhNode* n = nodes + node;
            if (n->count > 0) {
                for (nb_uint k = 0; k < n->count; ++k) {
                    const NB_GLOBAL NbGeomPrim* p = prims + n->offset + k;
                    if (!(p->flags & flag))
                        continue;
                    const float t = nbIntersectPrim(p, o, d, &r, tNear, tHit);
                    if (t < tHit) {
                        tHit = t;
                        found = 1;
                        if (anyHit)
                            return tHit;
                    }
                }
            } else {
                /* Both children: visit the nearer first, keep the other for later. */
                const nb_uint a = node + 1, b = n->offset;
                const float ta = nbBoxEntry(nodes + a, o, &r, tNear, tHit);
                const float tb = nbBoxEntry(nodes + b, o, &r, tNear, tHit);
                if (ta < NB_GEOM_MISS && tb < NB_GEOM_MISS) {
                    stack[top] = ta <= tb ? b : a;
                    stackT[top++] = ta <= tb ? tb : ta;
                    node = ta <= tb ? a : b;
                    continue;
                }
                if (ta < NB_GEOM_MISS || tb < NB_GEOM_MISS) {
                    node = ta < NB_GEOM_MISS ? a : b;
                    continue;
                }
            }
            /* Pop, skipping boxes that a hit found since lies in front of. */
            while (top > 0 && !(stackT[top - 1] <= tHit))
                --top;
            if (top == 0)
                break;
            node = stack[--top];
        }
    }
    return found ? tHit : NB_GEOM_MISS;
}

#endif
