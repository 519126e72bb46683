// Procedural generators through buildVolumes: exact box, sphere radius and volume, the default
// cloud, parameter errors, and writing a generated grid to a .vdb file.
#include "VolumeTestUtil.h"
#include "volume/Procedural.h"

#include <chrono>
#include <cmath>

using namespace nimbus;
using namespace nimbus::test;

TEST(Procedural, BoxIsExactHalfAVoxelInside)
{
    // Anisotropic: 16 x 8 x 3 voxels (0.25 / 0.0625 = 4, 0.1875 / 0.0625 = 3).
    auto v = buildOne(proceduralScene(
        "box", {{"size_x", 1.0}, {"size_y", 0.5}, {"size_z", 0.1875}, {"voxel_size", 0.0625}, {"density", 3.5}}));
    const float3 half = make_float3(0.5f, 0.25f, 0.09375f);
    const float h = 0.0625f;
    EXPECT_FLOAT_EQ(v->voxelSize, h);
    // Every point at least half a voxel (plus float round-off of the transform) inside: exact.
    const float margin = 0.5f * h + 1e-5f;
    for (int i = 0; i <= 20; ++i)
        for (int j = 0; j <= 20; ++j)
            for (int k = 0; k <= 20; ++k) {
                float3 p = make_float3((half.x - margin) * (i / 10.0f - 1.0f), (half.y - margin) * (j / 10.0f - 1.0f),
                                       (half.z - margin) * (k / 10.0f - 1.0f));
                ASSERT_EQ(densityAt(*v, p), 3.5f) << p.x << " " << p.y << " " << p.z;
            }
    // On a face: half the density; half a voxel outside: nothing.
    EXPECT_NEAR(densityAt(*v, make_float3(half.x, 0, 0)), 1.75f, 1e-4f);
    EXPECT_NEAR(densityAt(*v, make_float3(0, -half.y, 0)), 1.75f, 1e-4f);
    EXPECT_NEAR(densityAt(*v, make_float3(0, 0, half.z)), 1.75f, 1e-4f);
    EXPECT_EQ(densityAt(*v, make_float3(half.x + margin, 0, 0)), 0.0f);
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, -half.z - margin)), 0.0f);
    // The bound holds the half-voxel ramp and lies within a brick of it.
    EXPECT_TRUE(v->worldBounds.contains(half + splat(0.5f * h - 1e-4f)));
    EXPECT_TRUE(v->worldBounds.contains(-half - splat(0.5f * h - 1e-4f)));
    EXPECT_LT(v->worldBounds.hi.x, half.x + 9 * h);
    EXPECT_FLOAT_EQ(v->density.maxValue(), 3.5f);
}

TEST(Procedural, BoxSnapsVoxelsToTheFaces)
{
    // 1 / 0.3 is not an integer: 3 voxels of 1/3, so the faces stay at +-0.5.
    auto v = buildOne(proceduralScene("box", {{"size", 1.0}, {"voxel_size", 0.3}}));
    EXPECT_NEAR(v->voxelSize, 1.0f / 3.0f, 1e-6f);
    EXPECT_EQ(densityAt(*v, make_float3(0.33f, -0.33f, 0.33f)), 1.0f);
    EXPECT_NEAR(densityAt(*v, make_float3(0.5f, 0, 0)), 0.5f, 1e-4f);
}

TEST(Procedural, LargeBoxIsTilesAndCheap)
{
    auto t0 = std::chrono::steady_clock::now();
    auto v = buildOne(proceduralScene("box", {{"size", 16.0}, {"voxel_size", 0.125}}));  // 128^3 voxels
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(densityAt(*v, make_float3(3.3f, -7.9f, 0.1f)), 1.0f);
    EXPECT_LT(seconds, 5.0);
}

TEST(Procedural, SphereRadiusAndVolume)
{
    const double r = 1.0, h = 0.05, d = 2.0;
    auto v = buildOne(proceduralScene("sphere", {{"radius", r}, {"voxel_size", h}, {"density", d}}));
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 2.0f);
    const float inside = float(r - 0.5 * h - std::sqrt(3.0) * h), outside = float(r + 0.5 * h + std::sqrt(3.0) * h);
    for (float3 dir : {make_float3(1, 0, 0), make_float3(0, -1, 0), normalize(make_float3(1, 1, 1)),
                       normalize(make_float3(-0.3f, 0.8f, 0.5f))}) {
        EXPECT_EQ(densityAt(*v, dir * inside), 2.0f);
        EXPECT_EQ(densityAt(*v, dir * outside), 0.0f);
        // Half density on the radius, up to trilinear interpolation of a one-voxel smoothstep.
        EXPECT_NEAR(densityAt(*v, dir * float(r)), 1.0f, 0.3f);
    }
    // The integral of density is d * 4/3 pi r^3 up to the edge's second-order error.
    Bbox b = v->density.activeIndexBounds();
    double mass = 0.0;
    for (int k = int(b.lo.z); k <= int(b.hi.z); ++k)
        for (int j = int(b.lo.y); j <= int(b.hi.y); ++j)
            for (int i = int(b.lo.x); i <= int(b.hi.x); ++i)
                mass += v->density.voxel(i, j, k);
    mass *= h * h * h;
    EXPECT_NEAR(mass / (d * 4.0 / 3.0 * M_PI * r * r * r), 1.0, 0.005);
    EXPECT_NEAR(v->worldBounds.center().x, 0.0f, 0.5 * 8 * h);
}

TEST(Procedural, SphereFalloffCentredOnRadius)
{
    auto v = buildOne(proceduralScene("sphere", {{"radius", 1.0}, {"voxel_size", 0.02}, {"falloff", 0.4}}));
    EXPECT_NEAR(densityAt(*v, make_float3(0, 0, 1.0f)), 0.5f, 0.01f);
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0.75f)), 1.0f);
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 1.25f)), 0.0f);
    float mid = densityAt(*v, make_float3(0, 0, 0.9f));
    EXPECT_GT(mid, 0.5f);
    EXPECT_LT(mid, 1.0f);
}

TEST(Procedural, DefaultCloud)
{
    auto t0 = std::chrono::steady_clock::now();
    auto v = buildOne(proceduralScene("cloud", {}));
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("default cloud: %.2f s, %zu bricks, %.1f MB, extent %.2f x %.2f x %.2f m, voxel %.4f m\n", seconds,
                v->density.brickCount(), v->density.memoryBytes() / 1e6, v->worldBounds.extent().x,
                v->worldBounds.extent().y, v->worldBounds.extent().z, v->voxelSize);
    ASSERT_FALSE(v->density.empty());
    const float across = nbMaxComponent(v->worldBounds.extent()) / v->voxelSize;
    EXPECT_GE(across, 100.0f);
    EXPECT_LE(across, 250.0f);
    EXPECT_FLOAT_EQ(v->density.maxValue(), 1.0f);          // density ~1 inside
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 1.0f);  // a solid core
    EXPECT_EQ(densityAt(*v, v->worldBounds.hi + splat(0.1f)), 0.0f);
    EXPECT_FALSE(v->hasEmission());
    EXPECT_EQ(v->clampedVoxels, 0u);
    EXPECT_LT(seconds, 20.0);  // 5 s target on 2 cores; generous for loaded CI machines
}

TEST(Procedural, CloudIsDeterministicPerSeed)
{
    std::map<std::string, double> p{{"radius", 1.0}, {"voxel_size", 0.04}, {"seed", 7}};
    auto a = buildOne(proceduralScene("cloud", p));
    auto b = buildOne(proceduralScene("cloud", p));
    p["seed"] = 8;
    auto c = buildOne(proceduralScene("cloud", p));
    EXPECT_EQ(a->density.pool(), b->density.pool());
    EXPECT_EQ(a->density.table(), b->density.table());
    EXPECT_NE(a->density.pool(), c->density.pool());
}

TEST(Procedural, ParameterErrorsNameTheKey)
{
    auto err = [](const std::string& g, std::map<std::string, double> p) { return inputError(proceduralScene(g, p)); };
    EXPECT_NE(err("cloud", {{"bogus", 1}}).find("scene.json: volumes[0].source.bogus: unknown parameter"),
              std::string::npos);
    EXPECT_NE(err("sphere", {{"voxel_size", 0}}).find("scene.json: volumes[0].source.voxel_size: must be > 0"),
              std::string::npos);
    EXPECT_NE(err("sphere", {{"radius", -1}}).find("volumes[0].source.radius: must be > 0"), std::string::npos);
    EXPECT_NE(err("box", {{"size_y", 0}}).find("volumes[0].source.size_y"), std::string::npos);
    EXPECT_NE(err("cloud", {{"octaves", 2.5}}).find("volumes[0].source.octaves: must be an integer"),
              std::string::npos);
    std::string big = err("cloud", {{"radius", 50}, {"voxel_size", 0.01}});
    EXPECT_NE(big.find("volumes[0].source.voxel_size: the grid would have"), std::string::npos) << big;
    EXPECT_NE(err("box", {{"size", 1e4}, {"voxel_size", 1e-3}}).find("volumes[0].source.voxel_size"),
              std::string::npos);
    EXPECT_NE(err("torus", {}).find("volumes[0].source.generator: unknown generator 'torus'"), std::string::npos);
    EXPECT_EQ(err("box", {{"density", 0}}), "");  // an empty volume is fine
    for (const std::string& e : {err("cloud", {{"bogus", 1}}), big})
        EXPECT_EQ(e.find('\n'), std::string::npos);
}

// Issue 18's sweep: a box edge of 1e-45 m failed in OpenVDB's transform (exit 1), a voxel size of
// 1e300 m was reported as a singular volume transform and a huge radius named only voxel_size.
TEST(Procedural, LengthsAtTheEdgesOfFloatNameTheirKey)
{
    auto err = [](const std::string& g, std::map<std::string, double> p) { return inputError(proceduralScene(g, p)); };
    EXPECT_NE(err("box", {{"size_x", 1e-45}, {"voxel_size", 0.25}}).find("volumes[0].source.size_x: the voxel edge would be"),
              std::string::npos);
    EXPECT_NE(err("box", {{"size", 1e-30}}).find("volumes[0].source.size: the voxel edge would be"),
              std::string::npos);
    EXPECT_NE(err("box", {{"voxel_size", 1e-5}, {"size", 1e-4}}).find("volumes[0].source.voxel_size: the voxel edge"),
              std::string::npos);
    EXPECT_NE(err("sphere", {{"voxel_size", 1e-6}, {"radius", 1e-4}}).find("volumes[0].source.voxel_size"),
              std::string::npos);
    EXPECT_NE(err("cloud", {{"radius", 1e-7}}).find("volumes[0].source.radius: the voxel edge"), std::string::npos);
    EXPECT_NE(err("sphere", {{"voxel_size", 1e300}}).find("volumes[0].source.voxel_size: must be at most 1e+30 m"),
              std::string::npos);
    EXPECT_NE(err("sphere", {{"radius", 1e30}, {"voxel_size", 1}}).find("smaller radius or falloff"),
              std::string::npos);
    EXPECT_NE(err("box", {{"size_z", 1e30}}).find("smaller size (size_x, size_y, size_z)"), std::string::npos);
    EXPECT_EQ(err("box", {{"size", 1e-4}, {"voxel_size", 1e-4}}), "");  // the smallest edge builds
}

TEST(Procedural, ZeroDensityBoxIsEmpty)
{
    auto v = buildOne(proceduralScene("box", {{"density", 0}}));
    EXPECT_TRUE(v->density.empty());
    EXPECT_TRUE(v->worldBounds.empty());
}

TEST(Procedural, WrittenVdbRendersTheSame)
{
    ScratchDir dir;
    Scene generated = proceduralScene("cloud", {{"radius", 0.5}, {"voxel_size", 0.02}, {"seed", 3}});
    writeProceduralVdb(generated.volumes[0].source, dir / "cloud.vdb");
    auto a = buildOne(generated);
    auto b = buildOne(vdbScene(dir / "cloud.vdb"));
    EXPECT_EQ(a->density.pool(), b->density.pool());
    EXPECT_EQ(a->density.table(), b->density.table());
    EXPECT_EQ(a->voxelSize, b->voxelSize);
    EXPECT_THROW(writeProceduralVdb(generated.volumes[0].source, dir / "no/such/dir/cloud.vdb"), Error);
}

TEST(Procedural, VolumeTransformPlacesIt)
{
    Scene scene = proceduralScene("sphere", {{"radius", 0.5}, {"voxel_size", 0.05}});
    scene.volumes[0].transform = Transform::translate(3, 0, -1) * Transform::scale(2, 2, 2);
    auto v = buildOne(scene);
    EXPECT_FLOAT_EQ(v->voxelSize, 0.1f);
    EXPECT_EQ(densityAt(*v, make_float3(3, 0, -1)), 1.0f);
    EXPECT_EQ(densityAt(*v, make_float3(3.8f, 0, -1)), 1.0f);  // radius 1 after scaling
    EXPECT_EQ(densityAt(*v, make_float3(3, 1.2f, -1)), 0.0f);
    EXPECT_NEAR(v->worldBounds.center().x, 3.0f, 0.4f);
}
