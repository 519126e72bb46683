// HandMadeVolume.h: VolumeData built directly from a density function, without OpenVDB, for
// tests of the marchers that must not depend on the loaders.
#pragma once

#include "volume/VolumeData.h"

#include <memory>

namespace nimbus::test {

// Voxels [0, n)^3 of size `voxel` metres, the grid's index origin at world `origin`.
template <class F>
std::shared_ptr<VolumeData> handMadeVolume(int n, float voxel, float3 origin, F density, Medium medium = {})
{
    auto v = std::make_shared<VolumeData>();
    v->name = "handmade";
    v->medium = medium;
    int nb = (n + BrickGrid::kBrick) / BrickGrid::kBrick + 1;
    v->density.reset({-1, -1, -1}, {nb, nb, nb}, 1);
    for (int bz = 0; bz < nb; ++bz)
        for (int by = 0; by < nb; ++by)
            for (int bx = 0; bx < nb; ++bx) {
                float* vals = v->density.allocateBrick(bx, by, bz);
                for (int z = 0; z < BrickGrid::kStored; ++z)
                    for (int y = 0; y < BrickGrid::kStored; ++y)
                        for (int x = 0; x < BrickGrid::kStored; ++x) {
                            int i = (bx - 1) * 8 + x, j = (by - 1) * 8 + y, k = (bz - 1) * 8 + z;
                            bool inside = i >= 0 && j >= 0 && k >= 0 && i < n && j < n && k < n;
                            vals[(z * BrickGrid::kStored + y) * BrickGrid::kStored + x] =
                                inside ? density(i, j, k) : 0.0f;
                        }
            }
    v->density.pruneZeroBricks();
    v->worldFromIndex = Transform::translate(origin.x, origin.y, origin.z) * Transform::scale(voxel, voxel, voxel);
    v->indexFromWorld = v->worldFromIndex.inverse();
    v->worldBounds = v->worldFromIndex.box(v->density.activeIndexBounds());
    v->voxelSize = voxel;
    v->gridsRead = {"density"};
    return v;
}

}  // namespace nimbus::test
