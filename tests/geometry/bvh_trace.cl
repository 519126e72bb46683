/* bvh_trace.cl: the path tracer's geometry traversal (kernels/shared/geometry.h) run on the
 * OpenCL device for test_kernel_bvh.cpp: closest hits of holdout rays, any hits of shadow rays,
 * and the fields of the shared structs as the device compiler lays them out. */
#include "shared/geometry.h"

/* Ray i: origin rays[6i .. 6i+2], direction rays[6i+3 .. 6i+5]. closest[i]: the first holdout
 * in (0, inf), INFINITY for none; occluded[i]: 1 where a shadow caster lies in (0, tShadow). */
__kernel void traceRays(__global const NbBvhNode* nodes, __global const NbGeomPrim* prims, NbGeomScene g,
                        __global const float* rays, float tShadow, int n, __global float* closest,
                        __global int* occluded)
{
    const int i = (int)get_global_id(0);
    if (i >= n)
        return;
    const float3 o = make_float3(rays[6 * i], rays[6 * i + 1], rays[6 * i + 2]);
    const float3 d = make_float3(rays[6 * i + 3], rays[6 * i + 4], rays[6 * i + 5]);
    closest[i] = nbGeomTrace(nodes, prims, g, o, d, 0.0f, INFINITY, NB_GEOM_HOLDOUT, 0);
    occluded[i] = nbGeomTrace(nodes, prims, g, o, d, 0.0f, tShadow, NB_GEOM_SHADOWS, 1) < INFINITY ? 1 : 0;
}

/* Every field of nodes[1] and prims[1], read by name (index 1: the array stride is sizeof). */
__kernel void readLayout(__global const NbBvhNode* nodes, __global const NbGeomPrim* prims, NbGeomScene g,
                         __global float* out)
{
    if (get_global_id(0) != 0)
        return;
    __global const NbBvhNode* n = nodes + 1;
    out[0] = n->lo[0], out[1] = n->lo[1], out[2] = n->lo[2], out[3] = (float)n->offset;
    out[4] = n->hi[0], out[5] = n->hi[1], out[6] = n->hi[2], out[7] = (float)n->count;
    __global const NbGeomPrim* p = prims + 1;
    for (int k = 0; k < 12; ++k)
        out[8 + k] = p->data[k];
    out[20] = p->radius, out[21] = (float)p->type, out[22] = (float)p->flags, out[23] = (float)p->object;
    out[24] = (float)g.nodeCount, out[25] = (float)g.planeFirst, out[26] = (float)g.planeCount, out[27] = (float)g.pad;
    out[28] = (float)sizeof(NbBvhNode), out[29] = (float)sizeof(NbGeomPrim), out[30] = (float)sizeof(NbGeomScene);
}
