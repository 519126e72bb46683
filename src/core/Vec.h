// Vec.h: host vector types. float3 comes from the shared kernel header so that the host and the
// OpenCL path tracer use one copy of the vector math (STYLE rule 2).
#pragma once

#include "../../kernels/shared/compat.h"

#include <algorithm>
#include <cstdint>
#include <limits>

namespace nimbus {

using Rgb = float3;  // RGB triple in the scene-linear working space

struct Int3 {
    int32_t x = 0, y = 0, z = 0;
};

inline float3 splat(float v)
{
    return make_float3(v, v, v);
}
inline bool isFinite(float3 v)
{
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
inline float component(float3 v, int axis)
{
    return axis == 0 ? v.x : (axis == 1 ? v.y : v.z);
}
// floor(x) as an int for |x| < 2^31, without a libm call: baseline x86-64 has no SSE4.1 round
// instruction, so std::floor is a function call, and the hot loops take three per sample.
inline int floorToInt(float x)
{
    int i = int(x);  // truncates toward zero
    return i - (float(i) > x);
}

// Axis-aligned box. Empty when lo > hi on any axis.
struct Bbox {
    float3 lo = splat(std::numeric_limits<float>::infinity());
    float3 hi = splat(-std::numeric_limits<float>::infinity());

    bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    void expand(float3 p)
    {
        lo = fmin(lo, p);
        hi = fmax(hi, p);
    }
    void expand(const Bbox& b)
    {
        if (b.empty())
            return;
        expand(b.lo);
        expand(b.hi);
    }
    float3 center() const { return (lo + hi) * 0.5f; }
    float3 extent() const { return hi - lo; }
    bool contains(float3 p) const
    {
        return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z;
    }
    // Slab test: the parametric interval [t0, t1] of o + t d inside the box, clipped to
    // [tmin, tmax]. invD may hold infinities (axis-parallel rays); returns false if empty.
    bool intersect(float3 o, float3 invD, float tmin, float tmax, float& t0, float& t1) const
    {
        for (int a = 0; a < 3; ++a) {
            float oa = component(o, a), ia = component(invD, a);
            float ta = (component(lo, a) - oa) * ia;
            float tb = (component(hi, a) - oa) * ia;
            if (std::isnan(ta) || std::isnan(tb))  // o on the slab plane of a parallel ray
                continue;
            if (ta > tb)
                std::swap(ta, tb);
            tmin = std::max(tmin, ta);
            tmax = std::min(tmax, tb);
            if (tmin > tmax)
                return false;
        }
        t0 = tmin;
        t1 = tmax;
        return true;
    }
};

inline float3 safeInverse(float3 d)
{
    auto inv = [](float v) { return v != 0.0f ? 1.0f / v : std::numeric_limits<float>::infinity(); };
    return make_float3(inv(d.x), inv(d.y), inv(d.z));
}

}  // namespace nimbus
