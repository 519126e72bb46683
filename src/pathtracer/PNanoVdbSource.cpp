// PNanoVdbSource.cpp: see PNanoVdbSource.h and kernels/shared/nanogrid.h.
#include "PNanoVdbSource.h"

#include "../core/Error.h"

#include <fstream>
#include <sstream>

namespace nimbus {

namespace {

// What PNanoVDB's C mode needs from outside before the header: its integer types (OpenCL C has
// no <stdint.h>; macros, since some compilers, PoCL's among them, predefine the typedefs), a
// buffer of 32-bit words in global memory (PNANOVDB_BUF_CUSTOM: the buffer functions and the
// grid-type table accessor the C buffer would define), memcpy for its float/int reinterpretation,
// and doubles for its map getters (the path tracer never calls them).
constexpr const char* kPrelude = R"(/* PNanoVDB.h as OpenCL C: src/pathtracer/PNanoVdbSource.cpp */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#define uint8_t uchar
#define int8_t char
#define uint16_t ushort
#define int16_t short
#define uint32_t uint
#define int32_t int
#define uint64_t ulong
#define int64_t long
#define PNANOVDB_C
#define PNANOVDB_BUF_CUSTOM
#define PNANOVDB_MEMCPY_CUSTOM
typedef struct { __global const uint* data; } pnanovdb_buf_t;
static inline __attribute__((always_inline)) uint pnanovdb_buf_read_uint32(pnanovdb_buf_t buf, ulong byte_offset)
{
    return buf.data[byte_offset >> 2];
}
static inline __attribute__((always_inline)) ulong pnanovdb_buf_read_uint64(pnanovdb_buf_t buf, ulong byte_offset)
{
    return ((__global const ulong*)buf.data)[byte_offset >> 3];
}
typedef uint pnanovdb_grid_type_t;
#define PNANOVDB_GRID_TYPE_GET(grid_typeIn, nameIn) pnanovdb_grid_type_constants[grid_typeIn].nameIn
static inline void nbPnanovdbCopy(void* dst, const void* src, size_t n)
{
    for (size_t i = 0; i < n; ++i)
        ((uchar*)dst)[i] = ((const uchar*)src)[i];
}
#define pnanovdb_memcpy(dst, src, n) nbPnanovdbCopy((void*)(dst), (const void*)(src), (n))
)";

void replaceOnce(std::string& text, const std::string& from, const std::string& to, const std::string& path)
{
    const size_t at = text.find(from);
    if (at == std::string::npos)
        throw Error("path tracer: " + path + " lacks '" + from +
                    "'; the PNanoVDB kernel variant is written for NanoVDB 32.x's PNanoVDB.h");
    text.replace(at, from.size(), to);
}

}  // namespace

std::string pnanovdbOpenClSource()
{
    const std::string path = NIMBUS_PNANOVDB_HEADER;
    std::ifstream in(path, std::ios::binary);
    if (!in)
        throw Error("path tracer: cannot read " + path + " for the PNanoVDB kernel variant (install libnanovdb-dev)");
    std::ostringstream s;
    s << in.rdbuf();
    std::string text = s.str();
    // Program-scope variables live in __constant memory in OpenCL 1.2 (the C mode's first
    // definition); the integer types come from the prelude.
    replaceOnce(text, "#define PNANOVDB_STATIC_CONST static const", "#define PNANOVDB_STATIC_CONST __constant", path);
    size_t at = 0;
    while ((at = text.find("#include <stdint.h>", at)) != std::string::npos)
        text.replace(at, 19, "/* stdint: prelude */");
    return std::string(kPrelude) + text + "\n";
}

}  // namespace nimbus
