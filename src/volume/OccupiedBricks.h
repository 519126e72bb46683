// OccupiedBricks.h: the world-space corners of a grid's occupied bricks, for the projections
// that cull what cannot meet them (image tiles, shadow-map texels).
#pragma once

#include "../core/Transform.h"
#include "BrickGrid.h"

namespace nimbus {

// Calls visit(corners) with the eight world-space corners of each occupied brick's trilinear
// support (index box [origin, origin + 8]^3, apron included; a brick is occupied where its
// majorant is positive), corner i at origin + 8 (i & 1, (i >> 1) & 1, i >> 2). visit returns
// false to stop; so does this.
template <class Visit>
bool forEachOccupiedBrick(const BrickGrid& grid, const Transform& worldFromIndex, Visit&& visit)
{
    const float B = float(BrickGrid::kBrick);
    const float3 ex = worldFromIndex.vector(make_float3(B, 0, 0)), ey = worldFromIndex.vector(make_float3(0, B, 0)),
                 ez = worldFromIndex.vector(make_float3(0, 0, B));
    const Int3 lo = grid.brickLo(), dims = grid.dims();
    const std::vector<float>& majorant = grid.majorants();
    float3 corners[8];
    for (int bz = 0; bz < dims.z; ++bz)
        for (int by = 0; by < dims.y; ++by)
            for (int bx = 0; bx < dims.x; ++bx) {
                if (!(majorant[(size_t(bz) * dims.y + by) * dims.x + bx] > 0.0f))
                    continue;
                const float3 c0 =
                    worldFromIndex.point(make_float3(float(lo.x + bx) * B, float(lo.y + by) * B, float(lo.z + bz) * B));
                for (int i = 0; i < 8; ++i)
                    corners[i] = c0 + ex * float(i & 1) + ey * float((i >> 1) & 1) + ez * float(i >> 2);
                if (!visit(corners))
                    return false;
            }
    return true;
}

}  // namespace nimbus
