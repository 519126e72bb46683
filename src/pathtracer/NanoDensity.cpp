// NanoDensity.cpp: see NanoDensity.h. NanoVDB's GridBuilder (header only, no OpenVDB) makes the
// grid; a brick and a NanoVDB leaf cover the same 8^3 voxels, so every allocated brick becomes
// exactly one leaf, zeros included (they are set, so the leaf exists and a lookup in it reports
// level 0 like a lookup in an allocated brick).
#include "NanoDensity.h"

#include "../core/Error.h"

#include <nanovdb/util/GridBuilder.h>

#include <cstring>

namespace nimbus {

std::vector<uint32_t> buildNanoDensity(const BrickGrid& grid)
{
    if (grid.channels() != 1)
        throw Error("path tracer: the PNanoVDB variant reads 1-channel density grids only");
    nanovdb::GridBuilder<float> builder(0.0f, nanovdb::GridClass::FogVolume);
    auto acc = builder.getAccessor();
    const int B = BrickGrid::kBrick, S = BrickGrid::kStored;
    const Int3 lo = grid.brickLo(), dims = grid.dims();
    for (int z = 0; z < dims.z; ++z)
        for (int y = 0; y < dims.y; ++y)
            for (int x = 0; x < dims.x; ++x) {
                const int32_t brick = grid.table()[(size_t(z) * size_t(dims.y) + size_t(y)) * size_t(dims.x) + size_t(x)];
                if (brick < 0)
                    continue;
                const float* values = grid.pool().data() + size_t(brick) * BrickGrid::kBrickValues;
                const int bx = (lo.x + x) * B, by = (lo.y + y) * B, bz = (lo.z + z) * B;
                for (int k = 0; k < B; ++k)
                    for (int j = 0; j < B; ++j)
                        for (int i = 0; i < B; ++i)
                            acc.setValue(nanovdb::Coord(bx + i, by + j, bz + k), values[(k * S + j) * S + i]);
            }
    nanovdb::GridHandle<nanovdb::HostBuffer> handle = builder.getHandle(1.0, nanovdb::Vec3d(0.0), "density");
    std::vector<uint32_t> words((handle.size() + 3) / 4, 0u);
    std::memcpy(words.data(), handle.data(), handle.size());
    return words;
}

}  // namespace nimbus
