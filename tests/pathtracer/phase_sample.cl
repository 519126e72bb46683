/* phase_sample.cl: draws phase-function samples with the shared kernel code, for the device
 * chi-square test (test_pathtrace_device.cpp). Sample i uses the stream (seed 7, pixel 0,
 * sample i), exactly as the host test in tests/core/test_phase.cpp does. */
#include "shared/compat.h"
#include "shared/phase.h"
#include "shared/rng.h"

__kernel void samplePhase(NbPhase p, float wx, float wy, float wz, __global float* cosines, __global float* directions)
{
    const uint i = (uint)get_global_id(0);
    NbRng r = nbRngStart(7u, 0u, i);
    float u0 = nbRngNext(&r), u1 = nbRngNext(&r), u2 = nbRngNext(&r);
    float3 wi = make_float3(wx, wy, wz);
    float3 wo = nbPhaseSample(p, wi, u0, u1, u2);
    cosines[i] = dot(wo, wi);
    directions[3 * i + 0] = wo.x;
    directions[3 * i + 1] = wo.y;
    directions[3 * i + 2] = wo.z;
}

/* The OpenCL port of BrickGrid::sample3, evaluated at the given index-space points. */
#include "shared/brickgrid.h"

__kernel void sampleGrid(NbGridDesc g, __global const int* tables, __global const float* pools,
                         __global const float* points, __global float* values)
{
    const uint i = (uint)get_global_id(0);
    float3 p = make_float3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
    float3 v = nbGridSample3(g, tables, pools, p);
    values[3 * i + 0] = v.x;
    values[3 * i + 1] = v.y;
    values[3 * i + 2] = v.z;
}
