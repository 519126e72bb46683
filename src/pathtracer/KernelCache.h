// KernelCache.h: builds OpenCL programs from kernels/, keeping the compiled binaries on disk.
//
// A kernel specialised per scene (preprocessor defines) costs seconds to compile on PoCL and
// more on some GPU drivers; scenes of one production share a handful of variants. The cache
// key is a hash of everything that changes the binary: the kernel source, every header under
// kernels/shared/, the build options (defines included), the device name and version, the
// driver version and the platform. Location: $NIMBUS_CACHE_DIR, else
// $XDG_CACHE_HOME/nimbus/kernels, else ~/.cache/nimbus/kernels. Entries are written to a
// temporary file and renamed into place (atomic on POSIX), so concurrent renders never read a
// half-written binary; a corrupt or stale entry is rebuilt from source and replaced.
#pragma once

#include "OpenCl.h"

#include <string>

namespace nimbus {

struct ProgramBuild {
    ocl::Program program;
    bool fromCache = false;
    double seconds = 0;     // wall time of the load or build
    std::string cacheFile;  // empty when the cache could not be used
};

// The directory holding pathtrace.cl and shared/: $NIMBUS_KERNEL_DIR, else the source tree's.
std::string kernelDirectory();
std::string kernelCacheDirectory();

// Builds `file` (relative to kernelDirectory(), or absolute) with `-I kernelDirectory()` and
// `options`. Throws Error with the build log's first error line when compilation fails.
ProgramBuild buildProgram(const ocl::Context& ctx, const std::string& file, const std::string& options,
                          const std::string& prelude = "");

}  // namespace nimbus
