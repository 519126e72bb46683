// DataFiles.h: where the files nimbus reads at run time live: the OpenCL kernels, the built-in
// AX shaders, the shipped OCIO config and the chart script of `nimbus compare`. An installed nimbus (cmake --install) has them in
// <prefix>/share/nimbus/, found from the binary or library this code is linked into
// (<prefix>/bin/nimbus, <prefix>/lib[/<triplet>]/libnimbus_c.so); a build
// tree reads them from the source tree it was configured from (NIMBUS_SOURCE_DIR).
#pragma once

#include <string>

namespace nimbus {

enum class DataFile { Kernels, Shaders, OcioConfig, CompareCharts };

// The directory (Kernels, Shaders) or file (OcioConfig, CompareCharts) of the installed share/nimbus/ if this
// code runs from an install, else of the source tree.
std::string dataPath(DataFile which);

}  // namespace nimbus
