// CellReach.h against its two promises, on a procedural cloud: a cell it calls clear or unread has
// no medium anywhere inside (VolumeSet::sample finds no extinction on a lattice through it), and a
// cell is unread exactly where no medium cell lies within `reach` cells. Both at a cache fine enough to be classified
// voxel by voxel and coarse enough to be classified brick by brick.
#include "../render/SceneBuilders.h"

#include "render/RenderContext.h"
#include "vrl/CellReach.h"
#include "wkb/RadianceGrid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

using namespace nimbus;
using namespace nimbus::test;

TEST(CellReach, MediumCellsHoldAllTheMediumAndUnreadCellsAreOutOfReach)
{
    struct Case {
        double voxel;
        int maxCells;
    };
    // Voxels of about a cell, of a fifth of one (a cell per brick: classified brick by brick) and
    // of twice one (where a voxel's reach is resolved within it).
    for (const Case& cs : {Case{0.05, 48}, Case{0.05, 8}, Case{0.1, 48}}) {
        Scene scene = emptyScene(8, 8);
        scene.volumes.push_back(proceduralCloud(cs.voxel, splat(4.0f), splat(0.1f), 0.5f));
        auto ctx = RenderContext::create(scene, false);
        constexpr int kReach = 2;
        const int maxCells = cs.maxCells;
        wkb::RadianceGrid grid;
        grid.init(ctx->volumes.worldBounds(), 0.0f, maxCells);
        ASSERT_FALSE(grid.empty());
        const std::vector<uint8_t> cls = vrl::cellReach(ctx->volumes, grid, kReach);
        ASSERT_EQ(cls.size(), grid.cellCount());
        const int n[3] = {grid.size(0), grid.size(1), grid.size(2)};
        auto index = [&](int x, int y, int z) {
            return (size_t(z) * size_t(n[1]) + size_t(y)) * size_t(n[0]) + size_t(x);
        };

        // No extinction anywhere in a cell not marked as holding medium: a 4^3 lattice in each,
        // out to 1% of a cell from its faces.
        const float3 lo = grid.box().lo;
        const float at[4] = {0.01f, 0.34f, 0.67f, 0.99f};
        int checked = 0;
        for (int z = 0; z < n[2]; ++z)
            for (int y = 0; y < n[1]; ++y)
                for (int x = 0; x < n[0]; ++x) {
                    if (cls[index(x, y, z)] == vrl::kCellMedium)
                        continue;
                    for (int k = 0; k < 64; ++k) {
                        const float3 p =
                            lo + make_float3(float(x) + at[k & 3], float(y) + at[(k >> 2) & 3], float(z) + at[k >> 4]) *
                                     grid.cellSize();
                        ++checked;
                        ASSERT_EQ(ctx->volumes.sample(p).sigma_t.x, 0.0f)
                            << maxCells << " cells: medium at (" << p.x << ", " << p.y << ", " << p.z << ") in cell "
                            << x << " " << y << " " << z;
                    }
                }
        EXPECT_GT(checked, 0);

        // Unread exactly where no medium cell is within kReach (Chebyshev distance).
        int counts[3] = {0, 0, 0};
        for (int z = 0; z < n[2]; ++z)
            for (int y = 0; y < n[1]; ++y)
                for (int x = 0; x < n[0]; ++x) {
                    bool near = false;
                    for (int dz = -kReach; dz <= kReach && !near; ++dz)
                        for (int dy = -kReach; dy <= kReach && !near; ++dy)
                            for (int dx = -kReach; dx <= kReach && !near; ++dx) {
                                const int a = x + dx, b = y + dy, c = z + dz;
                                near = a >= 0 && b >= 0 && c >= 0 && a < n[0] && b < n[1] && c < n[2] &&
                                       cls[index(a, b, c)] == vrl::kCellMedium;
                            }
                    const uint8_t k = cls[index(x, y, z)];
                    ++counts[k];
                    ASSERT_EQ(k == vrl::kCellUnread, !near) << maxCells << " cells: cell " << x << " " << y << " " << z;
                }
        // The cloud leaves cells of all three kinds at the finer cache (else the test proves little).
        if (maxCells == 48 && cs.voxel < 0.08) {
            EXPECT_GT(counts[vrl::kCellUnread], 0);
            EXPECT_GT(counts[vrl::kCellClear], 0);
        }
        EXPECT_GT(counts[vrl::kCellMedium], 0);
    }
}
