// The PNanoVDB density variant (kernels/shared/nanogrid.h; issue 17, item 10): the NanoVDB grid
// rebuilt from a brick pool has one leaf per allocated brick and samples to the same bits as the
// pool (host, PNANOVDB_C); the path tracer's kernel with NB_GRID_PNANOVDB renders the image of the
// brick-pool kernel.
#include "PtWorld.h"

#include "../../kernels/shared/nanogrid.h"
#include "pathtracer/NanoDensity.h"
#include "volume/VolumeData.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

// The procedural cloud through the loader (its bricks' aprons are neighbouring voxels, as every
// loader makes them), at a voxel size that leaves many bricks pruned.
std::shared_ptr<VolumeData> loadedCloud(double voxel)
{
    Scene scene;
    scene.sourcePath = "scene.json";
    Volume v;
    v.name = "cloud";
    v.source.type = SourceType::Procedural;
    v.source.generator = "cloud";
    v.source.params = {{"voxel_size", voxel}};
    v.medium = medium(splat(8.0f), splat(0.2f), NbPhase{0.7f, 0, 0, 0});
    scene.volumes.push_back(v);
    auto volumes = buildVolumes(scene);
    return volumes.at(0);
}

}  // namespace

TEST(NanoDensity, OneLeafPerBrickAndTheSameSamplesBitForBit)
{
    auto cloud = loadedCloud(0.04);
    const BrickGrid& g = cloud->density;
    ASSERT_GT(g.brickCount(), 100u);
    std::vector<uint32_t> words = buildNanoDensity(g);
    // As the kernel sees it: the grid at a 32-byte aligned offset inside a float buffer.
    std::vector<float> pools(8 + words.size(), -1.0f);
    for (size_t i = 0; i < words.size(); ++i)
        std::memcpy(&pools[8 + i], &words[i], sizeof(uint32_t));
    NbGridDesc d{};
    d.poolOffset = 8;

    pnanovdb_buf_t buf = nbNanoBuf(pools.data(), 8);
    pnanovdb_grid_handle_t grid;
    grid.address.byte_offset = 0;
    pnanovdb_tree_handle_t tree = pnanovdb_grid_get_tree(buf, grid);
    EXPECT_EQ(pnanovdb_tree_get_node_count_leaf(buf, tree), uint32_t(g.brickCount()));
    EXPECT_EQ(pnanovdb_grid_get_grid_type(buf, grid), uint32_t(PNANOVDB_GRID_TYPE_FLOAT));

    // Points over the table and a margin beyond it, on voxel corners and faces too (t = 0).
    const Bbox b = g.activeIndexBounds();
    uint32_t state = 12345u;
    auto next = [&]() {
        state = state * 1664525u + 1013904223u;
        return float(state >> 8) / 16777216.0f;
    };
    size_t nonZero = 0;
    for (int s = 0; s < 200000; ++s) {
        float3 p = make_float3(b.lo.x - 4 + (b.hi.x - b.lo.x + 8) * next(), b.lo.y - 4 + (b.hi.y - b.lo.y + 8) * next(),
                               b.lo.z - 4 + (b.hi.z - b.lo.z + 8) * next());
        if (s % 4 == 0)
            p.x = std::floor(p.x);
        const float pool = g.sample(p), nano = nbNanoSample(d, pools.data(), p);
        nonZero += pool != 0.0f;
        ASSERT_EQ(std::memcmp(&pool, &nano, sizeof pool), 0)
            << "sample " << s << " at " << p.x << " " << p.y << " " << p.z << ": pool " << pool << ", nano " << nano;
    }
    EXPECT_GT(nonZero, 20000u) << "most points should fall in the cloud";
}

TEST(NanoDensity, PathtraceKernelRendersTheBrickPoolsImage)
{
    useTestKernelCache("nanogrid");
    World w(48, 36);
    w.volumes.push_back(loadedCloud(0.05));
    w.addLight(distantLight(make_float3(0.4f, -1.0f, -0.3f), splat(3.0f)));
    w.addLight(environmentLight(make_float3(0.1f, 0.15f, 0.25f)));
    lookAt(w.scene, make_float3(0.3f, 0.4f, 4.0f), make_float3(0, 0, 0), 40);
    w.scene.render.spp = 8;
    w.scene.render.seed = 3;
    PathtraceStats poolStats, nanoStats;
    PathtraceOptions pool, nano;
    pool.stats = &poolStats;
    nano.stats = &nanoStats;
    nano.pnanovdbDensity = true;
    Film a = w.render(pool);
    Film b = w.render(nano);
    EXPECT_NE(nanoStats.defines.find("NB_GRID_PNANOVDB=1"), std::string::npos);
    EXPECT_NE(poolStats.defines.find("NB_GRID_PNANOVDB=0"), std::string::npos);
    // Same seed, same majorants, densities equal to the bit: every path takes the same turns, so
    // the images agree but for float rounding of the kernel's own arithmetic.
    const Aov* pa = a.find("beauty");
    const Aov* pb = b.find("beauty");
    ASSERT_TRUE(pa && pb);
    size_t identical = 0, n = 0;
    double sum = 0;
    for (size_t k = 0; k < pa->pixels.size(); ++k) {
        if (k % 4 == 3)
            continue;  // alpha
        ++n;
        sum += pa->pixels[k];
        identical += std::memcmp(&pa->pixels[k], &pb->pixels[k], sizeof(float)) == 0;
        EXPECT_NEAR(pa->pixels[k], pb->pixels[k], 1e-5f * std::max(1.0f, std::fabs(pa->pixels[k]))) << "value " << k;
    }
    EXPECT_GT(sum, 0.0);
    std::printf("bit-identical beauty values: %zu of %zu\n", identical, n);
    EXPECT_GT(nanoStats.volumeBytes, 0u);
    std::printf("volume buffers: brick pool %zu bytes, PNanoVDB %zu bytes\n", poolStats.volumeBytes, nanoStats.volumeBytes);
}
