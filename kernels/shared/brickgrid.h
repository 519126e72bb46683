/* brickgrid.h: the OpenCL port of nimbus::BrickGrid (src/volume/BrickGrid.h), read-only.
 *
 * BrickGrid keeps three flat arrays: a dense table of brick slots (int32, -1 = empty), a pool of
 * bricks (8^3 cells stored as 9^3 values with a one-voxel apron, x fastest, channel innermost)
 * and one majorant per slot (the maximum of the brick's values, an exact bound for trilinear
 * lookups). The path tracer uploads these arrays unchanged, concatenated over all grids of the
 * scene; NbGridDesc says where one grid's part begins. The lookups below mirror
 * BrickGrid::sample and BrickGrid::majorantAt line for line, and tests/pathtracer checks that
 * both give the same numbers (as NanoVDB does for its C port, CNanoVDB.h).
 *
 * Index space follows OpenVDB: voxel (i,j,k) has its centre at integer coordinates; brick slot
 * (bx,by,bz) covers index positions [8 bx, 8 bx + 8) on each axis.
 */
#ifndef NIMBUS_KERNELS_SHARED_BRICKGRID_H
#define NIMBUS_KERNELS_SHARED_BRICKGRID_H

#include "compat.h"

#define NB_BRICK_LOG2 3
#define NB_BRICK 8
#define NB_BRICK_STORED 9
#define NB_BRICK_VALUES 729

/* Plain data, 48 bytes on host and device. A grid with channels == 0 is absent. */
typedef struct {
    int brickLo[4];         /* xyz: brick coordinates of table slot (0,0,0); w unused */
    int dims[4];            /* xyz: table size in bricks; w: channels (0 absent, 1 or 3) */
    nb_uint tableOffset;    /* first slot of this grid in the concatenated table buffer */
    nb_uint poolOffset;     /* first float of this grid's bricks in the pool buffer */
    nb_uint majorantOffset; /* first slot majorant of this grid in the majorant buffer */
    float maxValue;         /* the largest slot majorant (global-majorant mode) */
} NbGridDesc;

/* Table slot of brick (bx,by,bz), or -1 outside the table. */
NB_FN int nbGridSlot(NbGridDesc g, int bx, int by, int bz)
{
    int x = bx - g.brickLo[0], y = by - g.brickLo[1], z = bz - g.brickLo[2];
    if (x < 0 || y < 0 || z < 0 || x >= g.dims[0] || y >= g.dims[1] || z >= g.dims[2])
        return -1;
    return (z * g.dims[1] + y) * g.dims[0] + x;
}

/* Slot majorant of brick (bx,by,bz): 0 for empty slots and outside the table. */
NB_FN float nbGridMajorant(NbGridDesc g, NB_GLOBAL const float* majorants, int bx, int by, int bz)
{
    int slot = nbGridSlot(g, bx, by, bz);
    return slot < 0 ? 0.0f : majorants[g.majorantOffset + (nb_uint)slot];
}

/* Trilinear sample at index-space position p, channels 0..2 (a 1-channel grid is broadcast);
 * zero outside the allocated bricks. BrickGrid::sample3 on the host. */
NB_FN float3 nbGridSample3(NbGridDesc g, NB_GLOBAL const int* tables, NB_GLOBAL const float* pools, float3 p)
{
    float3 zero = make_float3(0.0f, 0.0f, 0.0f);
    if (!(fabs(p.x) < 1e9f && fabs(p.y) < 1e9f && fabs(p.z) < 1e9f))
        return zero;
    float fx = floor(p.x), fy = floor(p.y), fz = floor(p.z);
    int i = (int)fx, j = (int)fy, k = (int)fz;
    int bx = i >> NB_BRICK_LOG2, by = j >> NB_BRICK_LOG2, bz = k >> NB_BRICK_LOG2;
    int slot = nbGridSlot(g, bx, by, bz);
    if (slot < 0)
        return zero;
    int brick = tables[g.tableOffset + (nb_uint)slot];
    if (brick < 0)
        return zero;
    float tx = p.x - fx, ty = p.y - fy, tz = p.z - fz;
    int li = i - (bx << NB_BRICK_LOG2), lj = j - (by << NB_BRICK_LOG2), lk = k - (bz << NB_BRICK_LOG2);
    int ch = g.dims[3];
    int sx = ch, sy = NB_BRICK_STORED * ch, sz = NB_BRICK_STORED * NB_BRICK_STORED * ch;
    NB_GLOBAL const float* q = pools + g.poolOffset + (nb_ulong)brick * (nb_ulong)(NB_BRICK_VALUES * ch) +
                               (nb_ulong)(lk * sz + lj * sy + li * sx);
    float out[3];
    for (int c = 0; c < 3; ++c) {
        if (c >= ch) {
            out[c] = out[0];
            continue;
        }
        NB_GLOBAL const float* r = q + c;
        float c00 = r[0] + tx * (r[sx] - r[0]);
        float c10 = r[sy] + tx * (r[sy + sx] - r[sy]);
        float c01 = r[sz] + tx * (r[sz + sx] - r[sz]);
        float c11 = r[sz + sy] + tx * (r[sz + sy + sx] - r[sz + sy]);
        float c0 = c00 + ty * (c10 - c00);
        float c1 = c01 + ty * (c11 - c01);
        out[c] = c0 + tz * (c1 - c0);
    }
    return make_float3(out[0], out[1], out[2]);
}

/* Channel 0 only: the density lookup of the hot loops. */
NB_FN float nbGridSample(NbGridDesc g, NB_GLOBAL const int* tables, NB_GLOBAL const float* pools, float3 p)
{
    if (!(fabs(p.x) < 1e9f && fabs(p.y) < 1e9f && fabs(p.z) < 1e9f))
        return 0.0f;
    float fx = floor(p.x), fy = floor(p.y), fz = floor(p.z);
    int i = (int)fx, j = (int)fy, k = (int)fz;
    int bx = i >> NB_BRICK_LOG2, by = j >> NB_BRICK_LOG2, bz = k >> NB_BRICK_LOG2;
    int slot = nbGridSlot(g, bx, by, bz);
    if (slot < 0)
        return 0.0f;
    int brick = tables[g.tableOffset + (nb_uint)slot];
    if (brick < 0)
        return 0.0f;
    float tx = p.x - fx, ty = p.y - fy, tz = p.z - fz;
    int li = i - (bx << NB_BRICK_LOG2), lj = j - (by << NB_BRICK_LOG2), lk = k - (bz << NB_BRICK_LOG2);
    int ch = g.dims[3];
    int sx = ch, sy = NB_BRICK_STORED * ch, sz = NB_BRICK_STORED * NB_BRICK_STORED * ch;
    NB_GLOBAL const float* r = pools + g.poolOffset + (nb_ulong)brick * (nb_ulong)(NB_BRICK_VALUES * ch) +
                               (nb_ulong)(lk * sz + lj * sy + li * sx);
    float c00 = r[0] + tx * (r[sx] - r[0]);
    float c10 = r[sy] + tx * (r[sy + sx] - r[sy]);
    float c01 = r[sz] + tx * (r[sz + sx] - r[sz]);
    float c11 = r[sz + sy] + tx * (r[sz + sy + sx] - r[sz + sy]);
    float c0 = c00 + ty * (c10 - c00);
    float c1 = c01 + ty * (c11 - c01);
    return c0 + tz * (c1 - c0);
}

#endif
