// PNanoVdbSource.h: PNanoVDB.h as OpenCL C, prepended to pathtrace.cl for the NB_GRID_PNANOVDB
// kernel variant (kernels/shared/nanogrid.h explains why a copy and what is changed).
#pragma once

#include <string>

namespace nimbus {

// The header installed with libnanovdb-dev (found when nimbus was configured), in its C mode with
// a __global buffer, stdint names as OpenCL types, and its program-scope tables in __constant
// memory. Throws Error when the header is missing or not the layout this patch expects.
std::string pnanovdbOpenClSource();

}  // namespace nimbus
