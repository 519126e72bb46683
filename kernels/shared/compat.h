/* compat.h: the subset of C that OpenCL C and C++ share.
 *
 * Code under kernels/shared/ is compiled twice: by the OpenCL compiler for the path tracer, and
 * by the C++ compiler for the host (WKB marcher, single scattering, tests). This header gives
 * both sides the same spelling for vectors and math so that one copy of the math serves both
 * (pbrt-v4 does the same with PBRT_CPU_GPU).
 *
 * Rules for shared code: float only (no double), float3 for vectors, NB_FN on every function,
 * no pointers to private memory across functions except through NB_PRIVATE, no recursion.
 */
#ifndef NIMBUS_KERNELS_SHARED_COMPAT_H
#define NIMBUS_KERNELS_SHARED_COMPAT_H

#ifdef __OPENCL_VERSION__

/* OpenCL C follows C99 inline rules: a plain `inline` function has no external definition, so
 * a call the compiler chooses not to inline is left unresolved, which some drivers reject at
 * link. `static inline` gives every program its own definition. */
#define NB_FN static inline
#define NB_GLOBAL __global
#define NB_CONSTANT __constant
#define NB_PRIVATE __private
#define make_float3(a, b, c) ((float3)((a), (b), (c)))
typedef uint nb_uint;
typedef ulong nb_ulong;

#else /* C++ host */

#include <cmath>
#include <cstdint>

/* C++ `inline`: one definition across translation units (ODR), as a header function needs. */
#define NB_FN inline
#define NB_GLOBAL
#define NB_CONSTANT
#define NB_PRIVATE
typedef uint32_t nb_uint;
typedef uint64_t nb_ulong;

using std::acos;
using std::atan;
using std::atan2;
using std::cos;
using std::erf;
using std::exp;
using std::expm1;
using std::fabs;
using std::floor;
using std::fmax;
using std::fmin;
using std::log;
using std::log1p;
using std::pow;
using std::sin;
using std::sqrt;
using std::tan;

/* Three floats, the same operators OpenCL's float3 has. Host-side storage only: OpenCL's
 * float3 occupies 16 bytes in buffers, so structs shared with kernels use float[4] or float4. */
struct float3 {
    float x, y, z;
};
NB_FN float3 make_float3(float a, float b, float c)
{
    return float3{a, b, c};
}
NB_FN float3 operator+(float3 a, float3 b)
{
    return {a.x + b.x, a.y + b.y, a.z + b.z};
}
NB_FN float3 operator-(float3 a, float3 b)
{
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
NB_FN float3 operator*(float3 a, float3 b)
{
    return {a.x * b.x, a.y * b.y, a.z * b.z};
}
NB_FN float3 operator/(float3 a, float3 b)
{
    return {a.x / b.x, a.y / b.y, a.z / b.z};
}
NB_FN float3 operator*(float3 a, float s)
{
    return {a.x * s, a.y * s, a.z * s};
}
NB_FN float3 operator*(float s, float3 a)
{
    return {a.x * s, a.y * s, a.z * s};
}
NB_FN float3 operator/(float3 a, float s)
{
    return {a.x / s, a.y / s, a.z / s};
}
NB_FN float3 operator-(float3 a)
{
    return {-a.x, -a.y, -a.z};
}
NB_FN float3& operator+=(float3& a, float3 b)
{
    a = a + b;
    return a;
}
NB_FN float3& operator-=(float3& a, float3 b)
{
    a = a - b;
    return a;
}
NB_FN float3& operator*=(float3& a, float3 b)
{
    a = a * b;
    return a;
}
NB_FN float3& operator*=(float3& a, float s)
{
    a = a * s;
    return a;
}
NB_FN float dot(float3 a, float3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
NB_FN float3 cross(float3 a, float3 b)
{
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
NB_FN float length(float3 a)
{
    return std::sqrt(dot(a, a));
}
NB_FN float3 normalize(float3 a)
{
    return a / length(a);
}
NB_FN float3 exp(float3 a)
{
    return {std::exp(a.x), std::exp(a.y), std::exp(a.z)};
}
NB_FN float3 fmin(float3 a, float3 b)
{
    return {std::fmin(a.x, b.x), std::fmin(a.y, b.y), std::fmin(a.z, b.z)};
}
NB_FN float3 fmax(float3 a, float3 b)
{
    return {std::fmax(a.x, b.x), std::fmax(a.y, b.y), std::fmax(a.z, b.z)};
}
NB_FN float clamp(float v, float lo, float hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

#endif

#define NB_PI 3.14159265358979323846f
#define NB_INV_4PI 0.07957747154594767f
/* 1/(4 pi) for the host's double arithmetic (the WKB order sums and spherical harmonics, which
 * accumulate thousands of terms); shared code itself stays float and uses NB_INV_4PI. A macro,
 * not a constexpr, so that this header stays valid OpenCL C (where nothing uses it). */
#define NB_INV_4PI_D 0.079577471545947667884

/* fmin and fmax of two floats in hot loops (the majorant walk): OpenCL's builtins on the device;
 * on the host, comparisons with the same rule for a NaN (the other operand is returned): GCC
 * calls libm's fminf through the PLT for std::fmin, 6% of a vrl render's profile, and vrl renders
 * took 17% less time without it, with the same pixels (docs/benchmarks.md, 2026-12-07). */
#ifdef __OPENCL_VERSION__
#define nbFmin(a, b) fmin((a), (b))
#define nbFmax(a, b) fmax((a), (b))
#else
NB_FN float nbFmin(float a, float b)
{
    return (a < b || b != b) ? a : b;
}
NB_FN float nbFmax(float a, float b)
{
    return (a > b || b != b) ? a : b;
}
#endif

/* Plain comparisons rather than fmax/fmin: C++ compilers call libm for those (NaN rules). */
NB_FN float nbMaxComponent(float3 v)
{
    float m = v.x > v.y ? v.x : v.y;
    return m > v.z ? m : v.z;
}
NB_FN float nbMinComponent(float3 v)
{
    float m = v.x < v.y ? v.x : v.y;
    return m < v.z ? m : v.z;
}
// Divided, not multiplied by 1/3: the mean of three equal values must be that value exactly (an
// opaque-free pixel has alpha 1 - mean(T) = 0), which (1 + 1 + 1) * 0.33333334f, fused, is not.
NB_FN float nbAverage(float3 v)
{
    return (v.x + v.y + v.z) / 3.0f;
}

/* float[4] storage in plain-data structs to float3 (OpenCL float3 is 16 bytes in buffers). */
NB_FN float3 nbLoad3(const float* v)
{
    return make_float3(v[0], v[1], v[2]);
}

/* An orthonormal basis around unit vector n (Duff et al. 2017, branchless). */
NB_FN void nbBasis(float3 n, NB_PRIVATE float3* t, NB_PRIVATE float3* b)
{
    float sign = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (sign + n.z);
    float c = n.x * n.y * a;
    *t = make_float3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = make_float3(c, sign + n.y * n.y * a, -n.y);
}

#endif
