// NanoDensity.h: a density BrickGrid rebuilt as a NanoVDB float grid, for the path tracer's
// PNanoVDB kernel variant (kernels/shared/nanogrid.h; issue 17, item 10) and its test.
#pragma once

#include "../volume/BrickGrid.h"

#include <cstdint>
#include <vector>

namespace nimbus {

// The grid's bytes as 32-bit words (the buffer PNanoVDB reads): one leaf per allocated brick with
// the brick's 8^3 core values, index space unchanged (the transform stays the volume's), no tiles.
// A 1-channel grid only.
std::vector<uint32_t> buildNanoDensity(const BrickGrid& grid);

}  // namespace nimbus
