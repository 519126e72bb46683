// Volume shaders (OpenVDB AX) on procedural volumes: lookup, errors, custom density and emission.
#include "VolumeTestUtil.h"
#include "volume/VolumeShader.h"

#include "core/StopFlag.h"

#include <openvdb/openvdb.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <thread>

using namespace nimbus;
using namespace nimbus::test;

namespace {
Scene boxWithShader(const std::string& shader)
{
    return proceduralScene("box", {{"size", 1.0}, {"voxel_size", 0.125}, {"density", 2.0}}, shader);
}
}  // namespace

TEST(VolumeShader, DefaultIsFoundAndRecognised)
{
    for (std::string name : {"", "default", "default.ax"}) {
        ShaderFile f = findShader(name, "", "scene.json: volumes[0].shader");
        EXPECT_TRUE(f.isDefault) << name;
        EXPECT_NE(f.path.find("shaders/default.ax"), std::string::npos) << name;
    }
    EXPECT_FALSE(findShader("blackbody", "", "x").isDefault);
}

TEST(VolumeShader, MissingShaderNamesTheKey)
{
    std::string e = inputError(boxWithShader("nosuch"));
    EXPECT_EQ(e.rfind("scene.json: volumes[0].shader: shader 'nosuch' not found (searched: ", 0), 0u) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos);
}

TEST(VolumeShader, CompileErrorIsAnInputErrorWithTheAxMessage)
{
    ScratchDir dir;
    writeText(dir / "broken.ax", "@density = max(@density, 0.0f;\n");
    std::string e = inputError(boxWithShader(dir / "broken.ax"));
    EXPECT_EQ(e.rfind("scene.json: volumes[0].shader: AX error in '", 0), 0u) << e;
    EXPECT_NE(e.find("expecting"), std::string::npos) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos);

    writeText(dir / "unknown.ax", "@density = nosuchfunction(@density);\n");
    e = inputError(boxWithShader(dir / "unknown.ax"));
    EXPECT_NE(e.find("nosuchfunction"), std::string::npos) << e;
}

TEST(VolumeShader, ReadingAGridNobodySuppliedIsAnInputError)
{
    ScratchDir dir;
    writeText(dir / "reads.ax", "@density = @smoke;\n");
    std::string e = inputError(boxWithShader(dir / "reads.ax"));
    EXPECT_NE(e.find("volumes[0].shader"), std::string::npos) << e;
    EXPECT_NE(e.find("smoke"), std::string::npos) << e;
}

TEST(VolumeShader, CustomShaderMapsDensityAndEmission)
{
    ScratchDir dir;
    writeText(dir / "glow.ax", "// a test shader\n"
                               "@density = 3.0f * @density;\n"
                               "v@emission = {0.5f, 0.25f, 0.0f} * @density;\n");
    auto v = buildOne(boxWithShader(dir / "glow.ax"));
    EXPECT_EQ(densityAt(*v, make_float3(0.1f, 0.2f, -0.3f)), 6.0f);
    ASSERT_TRUE(v->hasEmission());
    EXPECT_EQ(v->emission.channels(), 3);
    float3 e = emissionAt(*v, make_float3(0.1f, 0.2f, -0.3f));
    EXPECT_FLOAT_EQ(e.x, 3.0f);
    EXPECT_FLOAT_EQ(e.y, 1.5f);
    EXPECT_EQ(e.z, 0.0f);
    EXPECT_EQ(emissionAt(*v, make_float3(0.8f, 0, 0)).x, 0.0f);
}

TEST(VolumeShader, NegativeShaderOutputIsClampedAndCounted)
{
    ScratchDir dir;
    writeText(dir / "negate.ax", "@density = -@density;\n");
    LogCatcher log;
    auto v = buildOne(boxWithShader(dir / "negate.ax"));
    EXPECT_TRUE(v->density.empty());
    EXPECT_EQ(v->clampedVoxels, 8u * 8u * 8u);
    ASSERT_EQ(log.warnings.size(), 1u);
    EXPECT_NE(log.warnings[0].find("clamped 512 voxel values (512 negative, 0 NaN, 0 infinite) to 0 [density]"),
              std::string::npos)
        << log.warnings[0];
}

TEST(VolumeShader, SearchPathFromEnvironment)
{
    ScratchDir dir;
    writeText(dir / "half.ax", "@density = 0.5f * @density;\n");
    ::setenv("NIMBUS_SHADER_PATH", ("/nonexistent:" + dir.str()).c_str(), 1);
    auto v = buildOne(boxWithShader("half"));
    ::unsetenv("NIMBUS_SHADER_PATH");
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 1.0f);
}

TEST(VolumeShader, ShaderNextToTheScene)
{
    ScratchDir dir;
    writeText(dir / "double.ax", "@density = 2.0f * @density;\n");
    Scene scene = boxWithShader("double");
    scene.sourcePath = dir / "scene.json";
    EXPECT_EQ(densityAt(*buildOne(scene), make_float3(0, 0, 0)), 4.0f);
    scene.volumes[0].shader = "./double.ax";
    EXPECT_EQ(densityAt(*buildOne(scene), make_float3(0, 0, 0)), 4.0f);
}

TEST(VolumeShader, DefaultShaderOnDensityOnlyVolumeLeavesEmissionOff)
{
    for (std::string shader : {"", "default"}) {
        auto v = buildOne(boxWithShader(shader));
        EXPECT_FALSE(v->hasEmission());
        EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 2.0f);
    }
    // blackbody.ax on a volume without temperature: it runs, and nothing glows.
    auto v = buildOne(boxWithShader("blackbody"));
    EXPECT_FALSE(v->hasEmission());
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 2.0f);
}

TEST(VolumeShader, OneCompilePerShaderForManyVolumes)
{
    ScratchDir dir;
    writeText(dir / "triple.ax", "@density = 3.0f * @density;\n");
    Scene scene = boxWithShader(dir / "triple.ax");
    scene.volumes.push_back(scene.volumes[0]);
    scene.volumes[1].transform = Transform::translate(5, 0, 0);
    auto volumes = buildVolumes(scene);
    ASSERT_EQ(volumes.size(), 2u);
    EXPECT_EQ(densityAt(*volumes[0], make_float3(0, 0, 0)), 6.0f);
    EXPECT_EQ(densityAt(*volumes[1], make_float3(5, 0, 0)), 6.0f);
    EXPECT_EQ(densityAt(*volumes[1], make_float3(0, 0, 0)), 0.0f);
}

// A relative shader resolves beside the scene first, then $NIMBUS_SHADER_PATH, then the
// built-in shaders; the error lists each place in that order.
TEST(VolumeShader, BesideTheSceneComesFirst)
{
    namespace fs = std::filesystem;
    ScratchDir dir;
    const fs::path sceneDir = dir / "scene", searchDir = dir / "search";
    fs::create_directories(sceneDir / "sub");
    fs::create_directories(searchDir);
    auto norm = [](const fs::path& p) { return p.lexically_normal().string(); };
    writeText(sceneDir / "blackbody.ax", "@density = 1.0f;\n");
    writeText(searchDir / "mine.ax", "@density = 1.0f;\n");
    writeText(sceneDir / "sub" / "mine.ax", "@density = 2.0f;\n");
    ::setenv("NIMBUS_SHADER_PATH", searchDir.c_str(), 1);
    EXPECT_EQ(findShader("blackbody", sceneDir, "x").path, norm(sceneDir / "blackbody.ax"));
    EXPECT_EQ(findShader("mine", sceneDir, "x").path, norm(searchDir / "mine.ax"));
    EXPECT_EQ(findShader("sub/mine", sceneDir, "x").path, norm(sceneDir / "sub" / "mine.ax"));
    EXPECT_NE(findShader("blackbody", "", "x").path.find("shaders/blackbody.ax"), std::string::npos);
    try {
        findShader("nowhere", sceneDir, "scene.json: volumes[0].shader");
        ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
        const std::string m = e.what();
        const size_t scene = m.find(norm(sceneDir / "nowhere"));
        const size_t search = m.find(norm(searchDir / "nowhere"));
        const size_t builtin = m.find("shaders/nowhere.ax");
        ASSERT_NE(scene, std::string::npos) << m;
        ASSERT_NE(search, std::string::npos) << m;
        ASSERT_NE(builtin, std::string::npos) << m;
        EXPECT_LT(scene, search) << m;
        EXPECT_LT(search, builtin) << m;
    }
    ::unsetenv("NIMBUS_SHADER_PATH");
}

namespace {

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;
using openvdb::Vec3SGrid;

// A density and a temperature grid on 0.1 m voxels: `n`^3 voxels of varied values (a hash of the
// coordinate, some negative for the shader to clamp), a 128^3 active tile of each, and inactive
// leaves of the temperature; the shader's inputs in many 64^3 blocks.
openvdb::GridPtrVec shaderInputs(int n)
{
    auto make = [](const char* name) {
        FloatGrid::Ptr g = FloatGrid::create(0.0f);
        g->setName(name);
        g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
        return g;
    };
    FloatGrid::Ptr d = make("density"), t = make("temperature");
    d->tree().fill(CoordBBox(Coord(0), Coord(n - 1)), 1.0f, true);
    t->tree().fill(CoordBBox(Coord(n / 3), Coord(n + 20)), 1.0f, true);
    d->tree().voxelizeActiveTiles();
    t->tree().voxelizeActiveTiles();
    auto hash = [](const Coord& c) {
        uint32_t h = uint32_t(c.x()) * 73856093u ^ uint32_t(c.y()) * 19349663u ^ uint32_t(c.z()) * 83492791u;
        h ^= h >> 13;
        h *= 0x5bd1e995u;
        return float(h >> 8) / float(1 << 24);
    };
    for (auto leaf = d->tree().beginLeaf(); leaf; ++leaf)
        for (auto v = leaf->beginValueOn(); v; ++v)
            v.setValue(2.0f * hash(v.getCoord()) - 0.2f);
    for (auto leaf = t->tree().beginLeaf(); leaf; ++leaf)
        for (auto v = leaf->beginValueOn(); v; ++v)
            v.setValue(800.0f + 2000.0f * hash(v.getCoord() + Coord(7)));
    d->tree().fill(CoordBBox(Coord(-256), Coord(-129)), 0.75f, true);  // one 128^3 tile
    t->tree().fill(CoordBBox(Coord(-256), Coord(-129)), 1700.0f, true);
    t->tree().fill(CoordBBox(Coord(n + 64, 0, 0), Coord(n + 79, 15, 15)), 3000.0f, false);
    return {d, t};
}

openvdb::GridPtrVec deepCopy(const openvdb::GridPtrVec& grids)
{
    openvdb::GridPtrVec out;
    for (const auto& g : grids)
        out.push_back(g->deepCopyGrid());
    return out;
}

// Every active value of `a` (voxels, and each tile at its two corners) is active in `b` with the
// same value, and both have as many active voxels.
template <class GridT>
void expectSameActiveValues(const GridT& a, const GridT& b, const char* what)
{
    ASSERT_EQ(a.tree().activeVoxelCount(), b.tree().activeVoxelCount()) << what;
    size_t checked = 0;
    for (auto it = a.tree().cbeginValueOn(); it; ++it) {
        openvdb::CoordBBox box;
        it.getBoundingBox(box);
        for (const Coord& c : {box.min(), box.max()}) {
            ASSERT_TRUE(b.tree().isValueOn(c)) << what << " at " << c;
            ASSERT_EQ(b.tree().getValue(c), *it) << what << " at " << c;
            ++checked;
        }
    }
    EXPECT_GT(checked, 0u) << what;
}

}  // namespace

// A shader run goes chunk by chunk so that a cancel can stop it (VolumeShader.cpp, runInChunks):
// the written grids' nodes move out by 64^3-voxel block, the shader runs on them beside the whole
// read-only grids, and they move back. Chunks of 4096 voxels (every 64^3 block a chunk of its
// own: the 100^3 voxels' eight, the tile's, the inactive leaves') give the same density,
// temperature and emission, value for value and voxel for voxel, as one chunk holding everything,
// for the default shader (writes @density and v@emission) and a custom one that writes
// @temperature and @density from both.
TEST(VolumeShader, ChunkedRunEqualsOneRun)
{
    ScratchDir dir;
    writeText(dir / "mix.ax", "@temperature = @temperature * 0.5f + 100.0f * @density;\n"
                              "@density = max(@density, 0.0f);\n");
    for (const std::string& path : {findShader("default", "", "x").path, std::string(dir / "mix.ax")}) {
        VolumeShader shader(path, "x");
        const openvdb::GridPtrVec inputs = shaderInputs(100);
        openvdb::GridPtrVec one = deepCopy(inputs), many = deepCopy(inputs);
        auto emissionOne = shader.run(one, "x", nullptr, 1e300);
        auto emissionMany = shader.run(many, "x", nullptr, 4096.0);
        for (size_t i = 0; i < 2; ++i)
            expectSameActiveValues(*openvdb::gridPtrCast<FloatGrid>(one[i]), *openvdb::gridPtrCast<FloatGrid>(many[i]),
                                   inputs[i]->getName().c_str());
        ASSERT_EQ(bool(emissionOne), shader.writesEmission());
        ASSERT_EQ(bool(emissionMany), shader.writesEmission());
        if (emissionOne)
            expectSameActiveValues(*openvdb::gridPtrCast<Vec3SGrid>(emissionOne),
                                   *openvdb::gridPtrCast<Vec3SGrid>(emissionMany), "emission");
        // The shader ran: the default clamps the negative densities, both shaders change values.
        FloatGrid::Ptr before = openvdb::gridPtrCast<FloatGrid>(inputs[0]),
                       after = openvdb::gridPtrCast<FloatGrid>(many[0]);
        float lowest = 0.0f;
        for (auto it = after->tree().cbeginValueOn(); it; ++it)
            lowest = std::min(lowest, *it);
        EXPECT_EQ(lowest, 0.0f) << path;
        EXPECT_LT(before->tree().getValue(Coord(3, 4, 5)), 1.0f);
        if (path.find("mix.ax") != std::string::npos) {  // and computed what it says, voxel by voxel
            FloatGrid::Ptr t0 = openvdb::gridPtrCast<FloatGrid>(inputs[1]),
                           t1 = openvdb::gridPtrCast<FloatGrid>(many[1]);
            for (const Coord& c : {Coord(50), Coord(60, 70, 99), Coord(99), Coord(-200), Coord(110, 100, 115)}) {
                ASSERT_TRUE(t0->tree().isValueOn(c)) << c;
                EXPECT_FLOAT_EQ(t1->tree().getValue(c),
                                t0->tree().getValue(c) * 0.5f + 100.0f * before->tree().getValue(c))
                    << c;
            }
        }
    }
}

// Cancel within a second (issue 18, item 3) reaches the shader's run, the largest part of loading
// a large fire (3.3e7 voxels with temperatures: ~7 s of 12): raised at 0.2 s into the default
// shader's run over 7.1e6 density and temperature voxels, the run throws Cancelled within one chunk.
TEST(VolumeShader, CancelStopsTheRunWithinOneChunk)
{
    VolumeShader shader(findShader("default", "", "x").path, "x");
    const openvdb::GridPtrVec inputs = shaderInputs(192);
    openvdb::GridPtrVec whole = deepCopy(inputs);
    const auto start = std::chrono::steady_clock::now();
    shader.run(whole, "x");
    const double uncancelled = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_GT(uncancelled, 0.3) << "the run must outlast the raise at 0.2 s";
    openvdb::GridPtrVec once = deepCopy(inputs);
    const auto oneStart = std::chrono::steady_clock::now();
    shader.run(once, "x", nullptr, 1e300);
    const double oneChunk = std::chrono::duration<double>(std::chrono::steady_clock::now() - oneStart).count();

    openvdb::GridPtrVec grids = deepCopy(inputs);
    const std::optional<double> after =
        secondsToCancel([&](const StopFlag* stop) { shader.run(grids, "x", stop); }, 200);
    ASSERT_TRUE(after) << "the run ended before the cancel at 0.2 s";
    EXPECT_LT(*after, 1.0);
    printf("shader run: %.2f s uncancelled in chunks, %.2f s in one; cancelled %.3f s after the raise\n", uncancelled,
           oneChunk, *after);
}
