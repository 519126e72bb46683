/* nanogrid.h: the path tracer's density lookup through NanoVDB's C port, PNanoVDB.h
 * (NB_GRID_PNANOVDB=1), the alternative to brickgrid.h's brick pool that issue 17 (item 10) asked
 * to measure. Figures and the decision: docs/benchmarks.md, "Path tracer: brick pool against
 * PNanoVDB".
 *
 * The volume's density BrickGrid is rebuilt as a NanoVDB float grid whose leaves are exactly its
 * allocated bricks (an 8^3 brick and a NanoVDB leaf cover the same voxels), values copied
 * (src/pathtracer/NanoDensity.cpp). The grid's bytes go up inside the pool buffer, 32-byte
 * aligned; the density NbGridDesc's poolOffset is then the grid's first 32-bit word, and its
 * table is unused. Its slot majorants stay the brick pool's (majorant.h reads only brickLo, dims
 * and majorantOffset), so the majorant walk is the same in both variants: only the density
 * fetches differ.
 *
 * nbNanoSample mirrors nbGridSample: trilinear over the eight voxels at floor(p) .. floor(p)+1,
 * the same formula in the same order, and zero when the voxel at floor(p) is not in a leaf (the
 * pool's "zero outside the allocated bricks"). A brick's apron holds its neighbours' voxels,
 * which here come from the neighbouring leaf, so both give the same number for every p
 * (tests/pathtracer/test_nanogrid.cpp checks it bit for bit on the host). That holds for every
 * pool the loaders build (VdbToBricks fills aprons from the neighbouring voxels; a pruned brick's
 * apron is zero); a pool written by hand with other apron values than its neighbours' would differ
 * in the last cell before an unallocated brick, where NanoVDB has no voxel to hold the apron.
 *
 * PNanoVDB 32.4 (Debian's libnanovdb-dev 10.0.1) has C, HLSL and GLSL modes but no OpenCL one.
 * The host compiles it as C (PNANOVDB_C). For OpenCL the host prepends a copy of the header to
 * the kernel source in its C mode with a custom buffer (a __global pointer) and its program-scope
 * tables moved to __constant memory, which OpenCL 1.2 requires (src/pathtracer/PNanoVdbSource.cpp);
 * this file then finds the declarations already there.
 */
#ifndef NIMBUS_KERNELS_SHARED_NANOGRID_H
#define NIMBUS_KERNELS_SHARED_NANOGRID_H

#include "brickgrid.h"

#ifndef __OPENCL_VERSION__
#ifndef PNANOVDB_C
#define PNANOVDB_C
#endif
#include <nanovdb/PNanoVDB.h>
#endif

/* The buffer view of the grid that starts `offset` 32-bit words into the pool buffer. */
NB_FN pnanovdb_buf_t nbNanoBuf(NB_GLOBAL const float* pools, nb_uint offset)
{
    pnanovdb_buf_t buf;
#ifdef __OPENCL_VERSION__
    buf.data = (__global const uint*)(pools + offset);
#else
    buf = pnanovdb_make_buf((uint32_t*)(pools + offset), 0);
#endif
    return buf;
}

/* Trilinear sample of a 1-channel grid at index-space position p; zero where the voxel at
 * floor(p) lies in no leaf. nbGridSample's twin (brickgrid.h). */
NB_FN float nbNanoSample(NbGridDesc g, NB_GLOBAL const float* pools, float3 p)
{
    if (!(fabs(p.x) < 1e9f && fabs(p.y) < 1e9f && fabs(p.z) < 1e9f))
        return 0.0f;
    float fx = floor(p.x), fy = floor(p.y), fz = floor(p.z);
    int i = (int)fx, j = (int)fy, k = (int)fz;
    pnanovdb_buf_t buf = nbNanoBuf(pools, g.poolOffset);
    pnanovdb_grid_handle_t grid;
    grid.address.byte_offset = 0;
    pnanovdb_root_handle_t root = pnanovdb_tree_get_root(buf, pnanovdb_grid_get_tree(buf, grid));
    pnanovdb_readaccessor_t acc;
    pnanovdb_readaccessor_init(&acc, root);
    pnanovdb_coord_t ijk;
    ijk.x = i, ijk.y = j, ijk.z = k;
    pnanovdb_uint32_t level = 0;
    pnanovdb_address_t a000 =
        pnanovdb_readaccessor_get_value_address_and_level(PNANOVDB_GRID_TYPE_FLOAT, buf, &acc, &ijk, &level);
    if (level != 0)
        return 0.0f;
    float v[8];
    if ((i & 7) < 7 && (j & 7) < 7 && (k & 7) < 7) {
        /* All eight in the leaf of a000 (about 2/3 of the lookups): a leaf's values are x-major,
         * offset (x << 6) | (y << 3) | z, so the others are fixed byte steps away. */
        for (int n = 0; n < 8; ++n)
            v[n] = pnanovdb_read_float(buf, pnanovdb_address_offset(a000, (pnanovdb_uint32_t)(
                                                                       4 * (((n & 1) << 6) | (((n >> 1) & 1) << 3) |
                                                                            ((n >> 2) & 1)))));
    } else {
        v[0] = pnanovdb_read_float(buf, a000);
        for (int n = 1; n < 8; ++n) {
            pnanovdb_coord_t c;
            c.x = i + (n & 1), c.y = j + ((n >> 1) & 1), c.z = k + ((n >> 2) & 1);
            v[n] = pnanovdb_read_float(
                buf, pnanovdb_readaccessor_get_value_address(PNANOVDB_GRID_TYPE_FLOAT, buf, &acc, &c));
        }
    }
    float tx = p.x - fx, ty = p.y - fy, tz = p.z - fz;
    float c00 = v[0] + tx * (v[1] - v[0]);
    float c10 = v[2] + tx * (v[3] - v[2]);
    float c01 = v[4] + tx * (v[5] - v[4]);
    float c11 = v[6] + tx * (v[7] - v[6]);
    float c0 = c00 + ty * (c10 - c00);
    float c1 = c01 + ty * (c11 - c01);
    return c0 + tz * (c1 - c0);
}

#endif
