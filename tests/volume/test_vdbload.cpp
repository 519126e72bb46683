// VDB files through buildVolumes: tiles versus voxels, placement, roles and their errors, bad
// values, empty grids, and emission through the default shader.
#include "VolumeTestUtil.h"
#include "core/StopFlag.h"
#include "volume/Procedural.h"
#include "volume/VdbFileReader.h"

#include <openvdb/io/Compression.h>
#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

#include <blosc.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <iterator>
#include <limits>
#include <thread>

using namespace nimbus;
using namespace nimbus::test;
using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;

namespace {

FloatGrid::Ptr floatGrid(const std::string& name, double voxelSize = 1.0)
{
    FloatGrid::Ptr g = FloatGrid::create(0.0f);
    g->setName(name);
    g->setGridClass(openvdb::GRID_FOG_VOLUME);
    g->setTransform(openvdb::math::Transform::createLinearTransform(voxelSize));
    return g;
}

void writeVdb(const std::string& path, openvdb::GridPtrVec grids)
{
    openvdb::initialize();
    openvdb::io::File(path).write(grids);
}

// Overwrites the three scale factors of the UniformScaleMap in the VDB file at `path` (the first
// three doubles equal to `scale` after the map's name; its stored reciprocals follow them) with
// `damaged`, as a corrupt or hand-edited file would hold them. Returns how many it overwrote.
int damageUniformScale(const std::string& path, double scale, double damaged)
{
    std::string bytes;
    {
        std::ifstream in(path, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    const size_t map = bytes.find("UniformScaleMap");
    if (map == std::string::npos)
        return 0;
    const std::string word(reinterpret_cast<const char*>(&scale), 8);
    int n = 0;
    for (size_t at = bytes.find(word, map); at != std::string::npos && n < 3; at = bytes.find(word, at + 8), ++n)
        std::memcpy(&bytes[at], &damaged, 8);
    writeText(path, bytes);
    return n;
}

// A deterministic point in [lo, hi] (a low-discrepancy sequence, so failures replay).
float3 samplePoint(int s, float3 lo, float3 hi)
{
    float u = std::fmod(s * 0.6180339887f, 1.0f), v = std::fmod(s * 0.7548776662f, 1.0f),
          w = std::fmod(s * 0.5698402910f, 1.0f);
    return lo + (hi - lo) * make_float3(u, v, w);
}

}  // namespace

TEST(VdbLoad, ActiveTilesRenderLikeVoxels)
{
    ScratchDir dir;
    FloatGrid::Ptr tiles = floatGrid("density", 0.25);
    auto& tree = tiles->tree();
    tree.fill(CoordBBox(Coord(-128, 0, 0), Coord(-1, 127, 127)), 0.5f, true);  // a 128^3 internal-node tile
    tree.fill(CoordBBox(Coord(-20, -5, 3), Coord(40, 30, 50)), 1.25f, true);   // 8^3 tiles and partial leaves
    tree.fill(CoordBBox(Coord(64, 64, 64), Coord(71, 71, 71)), 2.0f, true);    // one isolated 8^3 tile
    for (int i = 0; i < 50; ++i)
        tree.setValue(Coord(i, 2 * i - 10, 60 - i), 0.1f * (i % 7));        // voxels beside tiles
    tree.fill(CoordBBox(Coord(100, 0, 0), Coord(107, 7, 7)), 9.0f, false);  // inactive: not density
    ASSERT_GT(tree.activeTileCount(), 0u);
    FloatGrid::Ptr voxels = tiles->deepCopy();
    voxels->tree().voxelizeActiveTiles();
    ASSERT_EQ(voxels->tree().activeTileCount(), 0u);
    writeVdb(dir / "tiles.vdb", {tiles});
    writeVdb(dir / "voxels.vdb", {voxels});

    auto a = buildOne(vdbScene(dir / "tiles.vdb"));
    auto b = buildOne(vdbScene(dir / "voxels.vdb"));
    EXPECT_EQ(a->density.brickCount(), b->density.brickCount());
    EXPECT_EQ(a->density.maxValue(), 2.0f);
    EXPECT_EQ(a->density.majorants(), b->density.majorants());
    EXPECT_EQ(a->worldBounds.lo.x, b->worldBounds.lo.x);
    EXPECT_EQ(a->worldBounds.hi.z, b->worldBounds.hi.z);
    const float3 lo = make_float3(-34, -3, -3), hi = make_float3(20, 34, 34);  // world: index * 0.25
    for (int s = 0; s < 20000; ++s) {
        float3 p = samplePoint(s, lo, hi);
        ASSERT_EQ(densityAt(*a, p), densityAt(*b, p)) << "sample " << s << " at " << p.x << " " << p.y << " " << p.z;
    }
    // Inside each tile the density is the tile's value; the inactive block reads 0.
    EXPECT_EQ(densityAt(*a, make_float3(-10, 10, 10)), 0.5f);
    EXPECT_EQ(densityAt(*a, make_float3(16.9f, 16.9f, 16.9f)), 2.0f);
    EXPECT_EQ(densityAt(*a, make_float3(25.9f, 0.9f, 0.9f)), 0.0f);
}

TEST(VdbLoad, PlacementComposesGridAndVolumeTransforms)
{
    ScratchDir dir;
    FloatGrid::Ptr g = floatGrid("density", 0.5);
    g->transform().postTranslate(openvdb::Vec3d(1, 0, 0));      // the grid's own offset
    g->tree().fill(CoordBBox(Coord(0), Coord(3)), 1.0f, true);  // voxel centres at 1 + [0, 1.5]
    writeVdb(dir / "g.vdb", {g});
    Scene scene = vdbScene(dir / "g.vdb");
    scene.volumes[0].transform = Transform::translate(10, -2, 3);
    auto v = buildOne(scene);
    EXPECT_FLOAT_EQ(v->voxelSize, 0.5f);
    // Voxel (i,j,k) lands at (11 + i/2, -2 + j/2, 3 + k/2).
    float3 ip = v->indexFromWorld.point(make_float3(11.75f, -1.25f, 3.75f));
    EXPECT_NEAR(ip.x, 1.5f, 1e-5f);
    EXPECT_NEAR(ip.y, 1.5f, 1e-5f);
    EXPECT_NEAR(ip.z, 1.5f, 1e-5f);
    EXPECT_EQ(densityAt(*v, make_float3(11.75f, -1.25f, 3.75f)), 1.0f);
    EXPECT_EQ(densityAt(*v, make_float3(1.75f, 0.75f, 0.75f)), 0.0f);  // where it would be untransformed
    float3 w = v->worldFromIndex.point(make_float3(2, 0, 0));
    EXPECT_NEAR(w.x, 12.0f, 1e-5f);
    EXPECT_NEAR(w.y, -2.0f, 1e-5f);
    // The bound is that of the active bricks: index [-8, 8]^3.
    EXPECT_NEAR(v->worldBounds.lo.x, 11.0f - 4.0f, 1e-4f);
    EXPECT_NEAR(v->worldBounds.hi.x, 11.0f + 4.0f, 1e-4f);
    EXPECT_NEAR(v->worldBounds.lo.y, -2.0f - 4.0f, 1e-4f);
    EXPECT_NEAR(v->worldBounds.hi.z, 3.0f + 4.0f, 1e-4f);

    // A scaled and rotated volume: the smallest world edge is the voxel size.
    scene.volumes[0].transform = Transform::rotateDegrees(30, 0, 1, 0) * Transform::scale(2, 3, 4);
    v = buildOne(scene);
    EXPECT_NEAR(v->voxelSize, 1.0f, 1e-5f);
}

TEST(VdbLoad, RelativePathResolvesAgainstTheSceneFile)
{
    ScratchDir dir;
    FloatGrid::Ptr g = floatGrid("density");
    g->tree().setValue(Coord(1, 2, 3), 1.0f);
    writeVdb(dir / "rel.vdb", {g});
    Scene scene = vdbScene("rel.vdb");
    scene.sourcePath = dir / "scene.json";
    auto v = buildOne(scene);
    EXPECT_EQ(v->density.voxel(1, 2, 3), 1.0f);
    EXPECT_EQ(v->gridsRead, std::vector<std::string>{"density"});
}

TEST(VdbLoad, MissingFileAndGridsAreOneLineInputErrors)
{
    ScratchDir dir;
    EXPECT_EQ(inputError(vdbScene("/x/cloud.vdb")),
              "scene.json: volumes[0].source.file: cannot open '/x/cloud.vdb': no such file");

    FloatGrid::Ptr d = floatGrid("density"), t = floatGrid("temperature");
    d->tree().setValue(Coord(0), 1.0f);
    writeVdb(dir / "c.vdb", {d, t});
    const std::string file = dir / "c.vdb";
    EXPECT_EQ(inputError(vdbScene(file, {{"density", "dens"}})),
              "scene.json: volumes[0].source.grids.density: grid 'dens' not found in '" + file +
                  "' (grids: density, temperature)");
    EXPECT_EQ(inputError(vdbScene(file, {{"flame", "fire"}})),
              "scene.json: volumes[0].source.grids.flame: grid 'fire' not found in '" + file +
                  "' (grids: density, temperature)");
    EXPECT_NE(inputError(vdbScene(file, {{"heat", "fire"}})).find("volumes[0].source.grids.heat: grid 'fire'"),
              std::string::npos);

    Scene unnamed = vdbScene(file);
    unnamed.sourcePath.clear();
    writeVdb(dir / "t.vdb", {t});
    unnamed.volumes[0].source.file = dir / "t.vdb";
    EXPECT_EQ(inputError(unnamed).rfind("scene: volumes[0].source.grids.density: grid 'density' not found", 0), 0u);

    writeText(dir / "junk.vdb", "not a vdb file");
    std::string junk = inputError(vdbScene(dir / "junk.vdb"));
    EXPECT_EQ(junk.rfind("scene.json: volumes[0].source.file: cannot open '", 0), 0u) << junk;
    EXPECT_EQ(junk.find('\n'), std::string::npos);
}

TEST(VdbLoad, OptionalRolesAbsentByDefaultAreSkipped)
{
    ScratchDir dir;
    FloatGrid::Ptr d = floatGrid("smoke");
    d->tree().setValue(Coord(0), 1.0f);
    writeVdb(dir / "s.vdb", {d});
    auto v = buildOne(vdbScene(dir / "s.vdb", {{"density", "smoke"}}));
    EXPECT_EQ(v->density.voxel(0, 0, 0), 1.0f);
    EXPECT_FALSE(v->hasEmission());
}

TEST(VdbLoad, FrustumTransformIsRejected)
{
    ScratchDir dir;
    FloatGrid::Ptr g = floatGrid("density");
    g->setTransform(openvdb::math::Transform::createFrustumTransform(
        openvdb::BBoxd(openvdb::Vec3d(0), openvdb::Vec3d(10)), 0.5, 10.0, 1.0));
    g->tree().setValue(Coord(1), 1.0f);
    writeVdb(dir / "f.vdb", {g});
    std::string e = inputError(vdbScene(dir / "f.vdb"));
    EXPECT_NE(e.find("volumes[0].source.grids.density"), std::string::npos) << e;
    EXPECT_NE(e.find("non-linear"), std::string::npos) << e;
}

TEST(VdbLoad, BadValuesAreClampedAndCountedOnce)
{
    ScratchDir dir;
    FloatGrid::Ptr g = floatGrid("density");
    auto& tree = g->tree();
    tree.fill(CoordBBox(Coord(0), Coord(31)), 1.0f, true);
    for (int i = 0; i < 5; ++i)
        tree.setValue(Coord(i, 1, 1), -0.5f);
    tree.setValue(Coord(2, 2, 2), std::numeric_limits<float>::quiet_NaN());
    tree.setValue(Coord(3, 3, 3), std::numeric_limits<float>::quiet_NaN());
    tree.setValue(Coord(4, 4, 4), std::numeric_limits<float>::infinity());
    tree.setValue(Coord(5, 5, 5), -std::numeric_limits<float>::infinity());
    tree.addTile(1, Coord(64, 0, 0), -3.0f, true);  // 512 negative voxels as one tile
    writeVdb(dir / "bad.vdb", {g});

    LogCatcher log;
    auto v = buildOne(vdbScene(dir / "bad.vdb"));
    EXPECT_EQ(v->clampedVoxels, 5u + 2u + 2u + 512u);
    ASSERT_EQ(log.warnings.size(), 1u);
    EXPECT_EQ(log.warnings[0],
              "volume 'cloud': clamped 521 voxel values (517 negative, 2 NaN, 2 infinite) to 0 [density]");
    EXPECT_EQ(v->density.voxel(2, 2, 2), 0.0f);
    EXPECT_EQ(v->density.voxel(4, 4, 4), 0.0f);
    EXPECT_EQ(v->density.voxel(6, 6, 6), 1.0f);
    EXPECT_EQ(v->density.maxValue(), 1.0f);
    EXPECT_EQ(densityAt(*v, make_float3(66, 3, 3)), 0.0f);
    for (float m : v->density.majorants())
        EXPECT_TRUE(std::isfinite(m));
    for (int s = 0; s < 2000; ++s)
        ASSERT_TRUE(std::isfinite(densityAt(*v, samplePoint(s, make_float3(-2, -2, -2), make_float3(34, 34, 34)))));
}

TEST(VdbLoad, EmptyGridIsAnEmptyVolume)
{
    ScratchDir dir;
    writeVdb(dir / "empty.vdb", {floatGrid("density")});
    auto v = buildOne(vdbScene(dir / "empty.vdb"));
    EXPECT_TRUE(v->density.empty());
    EXPECT_TRUE(v->worldBounds.empty());
    EXPECT_FALSE(v->hasEmission());
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 0.0f);
}

TEST(VdbLoad, TemperatureEmitsThroughTheDefaultShader)
{
    ScratchDir dir;
    FloatGrid::Ptr d = floatGrid("density", 0.1), t = floatGrid("temperature", 0.1);
    d->tree().fill(CoordBBox(Coord(0), Coord(15)), 1.0f, true);
    t->tree().fill(CoordBBox(Coord(0), Coord(7)), 1500.0f, true);
    t->tree().fill(CoordBBox(Coord(8, 0, 0), Coord(15, 7, 7)), 3000.0f, true);
    writeVdb(dir / "fire.vdb", {d, t});
    auto v = buildOne(vdbScene(dir / "fire.vdb"));
    ASSERT_TRUE(v->hasEmission());
    EXPECT_EQ(v->gridsRead, (std::vector<std::string>{"density", "temperature"}));
    float3 e1500 = emissionAt(*v, make_float3(0.35f, 0.35f, 0.35f));  // voxel (3.5, 3.5, 3.5)
    float3 e3000 = emissionAt(*v, make_float3(1.15f, 0.35f, 0.35f));
    EXPECT_TRUE(isFinite(e1500) && isFinite(e3000));
    EXPECT_GT(e1500.x, 0.0f);
    EXPECT_GT(e1500.x, e1500.y);  // a 1500 K blackbody is orange-red
    EXPECT_GE(e1500.z, 0.0f);
    // At the 1500 K reference the luminance is 1 before the gamut clamp (blue -0.066 -> 0):
    // R, G = 3.1754, 0.46070 (docs/volumes.md). Hotter is brighter and bluer.
    EXPECT_NEAR(e1500.x, 3.1754f, 1e-3f);
    EXPECT_NEAR(e1500.y, 0.46070f, 1e-4f);
    EXPECT_EQ(e1500.z, 0.0f);
    EXPECT_GT(e3000.y, 1000.0f * e1500.y);
    EXPECT_GT(e3000.z / e3000.x, e1500.z / e1500.x);
    EXPECT_EQ(emissionAt(*v, make_float3(0.35f, 1.15f, 0.35f)).x, 0.0f);  // no temperature there
    EXPECT_EQ(densityAt(*v, make_float3(0.35f, 1.15f, 0.35f)), 1.0f);

    // With a flame grid (named "heat" in the file), emission is flame times the blackbody.
    FloatGrid::Ptr f = floatGrid("heat", 0.1);
    f->tree().fill(CoordBBox(Coord(0), Coord(7)), 0.5f, true);
    writeVdb(dir / "flame.vdb", {d, t, f});
    v = buildOne(vdbScene(dir / "flame.vdb"));
    float3 half = emissionAt(*v, make_float3(0.35f, 0.35f, 0.35f));
    EXPECT_NEAR(half.x, 0.5f * e1500.x, 1e-4f);
    EXPECT_EQ(emissionAt(*v, make_float3(1.15f, 0.35f, 0.35f)).x, 0.0f);  // flame 0 there
}

TEST(VdbLoad, CoarserTemperatureIsResampledOntoTheDensityVoxels)
{
    ScratchDir dir;
    FloatGrid::Ptr d = floatGrid("density", 0.5), t = floatGrid("temperature", 1.0);
    d->tree().fill(CoordBBox(Coord(0), Coord(31)), 1.0f, true);
    t->tree().fill(CoordBBox(Coord(0), Coord(7)), 2000.0f, true);  // world [0, 7]
    writeVdb(dir / "mixed.vdb", {d, t});
    auto v = buildOne(vdbScene(dir / "mixed.vdb", {}, "blackbody"));
    EXPECT_GT(emissionAt(*v, make_float3(3, 3, 3)).x, 10.0f);
    EXPECT_EQ(emissionAt(*v, make_float3(12, 12, 12)).x, 0.0f);
}

TEST(VdbLoad, ProceduralGridsAreFloatGridsWithTiles)
{
    VolumeSource box;
    box.generator = "box";
    box.params = {{"size", 4.0}, {"voxel_size", 0.0625}};  // 64^3 voxels
    openvdb::FloatGrid::Ptr g = makeProceduralGrid(box, "volumes[0].source");
    EXPECT_EQ(g->getName(), "density");
    EXPECT_GT(g->tree().activeTileCount(), 0u);
    EXPECT_EQ(g->tree().activeVoxelCount(), 64u * 64u * 64u);
    EXPECT_EQ(g->tree().leafCount(), 0u);  // 64 is a multiple of 8: tiles only
    EXPECT_NEAR(g->transform().indexToWorld(Coord(0)).x(), -2.0 + 0.03125, 1e-12);
}

// Failure 8 of issue 18: a VDB file whose transform is singular or non-finite exited 1 (an
// ArithmeticError deep in the build) instead of 2. The file is written, then its map's scale
// bytes are overwritten, as a corrupt or hand-edited file would hold them.
TEST(VdbLoad, InvalidTransformInTheFileIsAnInputError)
{
    ScratchDir dir;
    for (double bad : {0.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
        const std::string path = dir / "bad.vdb";
        FloatGrid::Ptr grid = FloatGrid::create(0.0f);
        grid->setName("density");
        grid->setTransform(openvdb::math::Transform::createLinearTransform(0.125));
        grid->tree().setValue(Coord(0, 0, 0), 1.0f);
        writeVdb(path, {grid});
        ASSERT_EQ(damageUniformScale(path, 0.125, bad), 3);
        const std::string message = inputError(vdbScene(path));
        EXPECT_NE(message.find("volumes[0].source.grids.density"), std::string::npos) << bad << ": " << message;
        EXPECT_NE(message.find("transform"), std::string::npos) << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
}

// Issue 18, item 5: VdbFileReader checks every compressed block before OpenVDB reads it (a
// damaged block overflowed the heap in OpenVDB 10's bloscFromStream). Every layout OpenVDB
// writes must still read, value for value as OpenVDB's own reader (io::File) gives it: each
// compression (none, zip, Blosc, each with and without active-mask compression), half floats,
// and each grid type's tree, with inactive values of every kind the mask compression stores
// (none, -background, one and two other values, more), voxels and tiles at every level.
namespace {

template <class GridT>
typename GridT::Ptr layoutGrid(const std::string& name, typename GridT::ValueType background,
                               std::function<typename GridT::ValueType(int)> value)
{
    typename GridT::Ptr g = GridT::create(background);
    g->setName(name);
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
    auto acc = g->getAccessor();
    int i = 0;
    // Leaves: fully active, half active (inactive background), inactive -background, one other
    // inactive value, two other inactive values, many inactive values.
    for (int leaf = 0; leaf < 6; ++leaf)
        for (int x = 0; x < 8; ++x)
            for (int y = 0; y < 8; ++y)
                for (int z = 0; z < 8; ++z) {
                    const Coord c(leaf * 8 + x, y, z);
                    const bool on = leaf == 0 || (x + y + z) % 2 == 0;
                    if (on)
                        acc.setValueOn(c, value(++i));
                    else if (leaf == 2)
                        acc.setValueOff(c, openvdb::math::negative(background));
                    else if (leaf == 3)
                        acc.setValueOff(c, value(7));
                    else if (leaf == 4)
                        acc.setValueOff(c, value(z % 2 ? 7 : 8));
                    else if (leaf == 5)
                        acc.setValueOff(c, value(1000 + ++i));
                    else
                        acc.setValueOff(c, background);
                }
    // Tiles: an active 8^3 tile in a lower internal node, a 128^3 one in an upper node, an
    // inactive non-background tile, and a root tile.
    g->tree().addTile(1, Coord(64, 0, 0), value(3), true);
    g->tree().addTile(2, Coord(256, 0, 0), value(4), true);
    g->tree().addTile(1, Coord(72, 0, 0), value(5), false);
    g->tree().addTile(3, Coord(-4096, 0, 0), value(6), true);
    return g;
}

template <class GridT>
void expectSameGrid(const GridT& read, const GridT& reference, const std::string& what)
{
    EXPECT_EQ(read.tree().leafCount(), reference.tree().leafCount()) << what;
    EXPECT_EQ(read.tree().activeVoxelCount(), reference.tree().activeVoxelCount()) << what;
    EXPECT_EQ(read.tree().activeTileCount(), reference.tree().activeTileCount()) << what;
    EXPECT_TRUE(read.tree().hasSameTopology(reference.tree())) << what;
    size_t differ = 0;
    auto acc = read.getConstAccessor();
    for (auto it = reference.tree().cbeginValueAll(); it; ++it)
        if (!(acc.getValue(it.getCoord()) == *it) || acc.isValueOn(it.getCoord()) != it.isValueOn())
            ++differ;
    EXPECT_EQ(differ, 0u) << what;
}

std::string readBytes(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// VdbFileReader's message for the file, or "" where the grid reads.
std::string readError(const std::string& path, const std::string& grid)
{
    try {
        VdbFileReader reader(path);
        reader.readGrid(grid);
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(VdbFileReader, ReadsEveryCompressionAndGridTypeAsOpenVdbDoes)
{
    namespace io = openvdb::io;
    openvdb::initialize();
    ScratchDir dir;
    auto f = [](int i) { return float(i) * 0.37f - 20.0f; };
    for (uint32_t compression : std::vector<uint32_t>{io::COMPRESS_NONE, io::COMPRESS_ACTIVE_MASK, io::COMPRESS_ZIP,
                                                      io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK, io::COMPRESS_BLOSC,
                                                      io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK}) {
        for (bool half : {false, true}) {
            openvdb::GridPtrVec grids;
            grids.push_back(layoutGrid<FloatGrid>("float", 0.25f, f));
            grids.push_back(layoutGrid<openvdb::DoubleGrid>("double", 0.0, [&](int i) { return double(f(i)); }));
            grids.push_back(layoutGrid<openvdb::Vec3SGrid>(
                "vec3s", openvdb::Vec3s(0.0f), [&](int i) { return openvdb::Vec3s(f(i), f(i + 1), -f(i)); }));
            grids.push_back(layoutGrid<openvdb::Int32Grid>("int32", 0, [](int i) { return i * 3 - 100; }));
            grids.push_back(layoutGrid<openvdb::BoolGrid>("bool", false, [](int i) { return i % 3 == 0; }));
            for (auto& g : grids)
                g->setSaveFloatAsHalf(half);
            const std::string path = dir / "layout.vdb";
            {
                io::File file(path);
                file.setCompression(compression);
                file.write(grids);
            }
            // The same grids streamed (io::Stream: no grid offsets, each grid after its descriptor).
            const std::string streamedPath = dir / "streamed.vdb";
            {
                std::ofstream out(streamedPath, std::ios::binary);
                io::Stream stream(out);
                stream.setCompression(compression);
                stream.write(grids);
            }
            io::File reference(path);
            reference.open(false);
            VdbFileReader reader(path), streamed(streamedPath);
            const std::string what = "compression " + std::to_string(compression) + (half ? ", half" : "");
            for (const std::string name : {"float", "double", "vec3s", "int32", "bool"}) {
                SCOPED_TRACE(what + ", grid " + name);
                openvdb::GridBase::Ptr read, fromStream, expected = reference.readGrid(name);
                ASSERT_NO_THROW(read = reader.readGrid(name));
                ASSERT_NO_THROW(fromStream = streamed.readGrid(name));
                EXPECT_EQ(fromStream->metaValue<std::string>("file_compression"),
                          read->metaValue<std::string>("file_compression"));
                // Written as asked (OpenVDB drops zip for fog volumes and level sets only).
                const std::string written = read->metaValue<std::string>("file_compression");
                const bool blosc = written.find("blosc") != std::string::npos;
                const bool zip = written.find("zip") != std::string::npos;
                EXPECT_EQ(blosc, bool(compression & io::COMPRESS_BLOSC)) << written;
                EXPECT_EQ(zip, bool(compression & io::COMPRESS_ZIP)) << written;
                for (const auto& got : {read, fromStream}) {
                    if (name == "float")
                        expectSameGrid(*openvdb::gridPtrCast<FloatGrid>(got),
                                       *openvdb::gridPtrCast<FloatGrid>(expected), name);
                    if (name == "double")
                        expectSameGrid(*openvdb::gridPtrCast<openvdb::DoubleGrid>(got),
                                       *openvdb::gridPtrCast<openvdb::DoubleGrid>(expected), name);
                    if (name == "vec3s")
                        expectSameGrid(*openvdb::gridPtrCast<openvdb::Vec3SGrid>(got),
                                       *openvdb::gridPtrCast<openvdb::Vec3SGrid>(expected), name);
                    if (name == "int32")
                        expectSameGrid(*openvdb::gridPtrCast<openvdb::Int32Grid>(got),
                                       *openvdb::gridPtrCast<openvdb::Int32Grid>(expected), name);
                    if (name == "bool")
                        expectSameGrid(*openvdb::gridPtrCast<openvdb::BoolGrid>(got),
                                       *openvdb::gridPtrCast<openvdb::BoolGrid>(expected), name);
                }
            }
        }
    }
}

// The damage fuzz_vdb found (tests/fuzz/regressions/vdb/blosc_block_overflows_its_buffer.vdb)
// and its relatives, made by hand in the last leaf's block: the block size word (8 bytes
// before the block, whose end is the file's) and Blosc's header (its uncompressed size at +4,
// its compressed size at +12). Each is refused naming the block, before OpenVDB reads it: under
// ASan (san.VdbFileReader.*) the first case was a heap-buffer-overflow.
TEST(VdbFileReader, DamagedCompressedBlocksAreRefusedBeforeOpenVdbReadsThem)
{
    namespace io = openvdb::io;
    openvdb::initialize();
    ScratchDir dir;
    const std::vector<uint32_t> compressions = {io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK,
                                               io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK};
    for (uint32_t compression : compressions) {
        FloatGrid::Ptr grid = floatGrid("density");
        grid->setGridClass(openvdb::GRID_UNKNOWN);  // OpenVDB writes fog volumes without zip
        for (int i = 0; i < 512; ++i)
            grid->tree().setValueOn(Coord(i / 64, i / 8 % 8, i % 8), 1.0f + float(i % 7) * 0.5f);  // compressible
        const std::string good = dir / "good.vdb";
        {
            io::File file(good);
            file.setCompression(compression);
            file.write({grid});
        }
        const std::string data = readBytes(good);
        // The size word whose block runs to the end of the file (negative: stored uncompressed,
        // as zip stores what it cannot shrink).
        size_t word = std::string::npos;
        bool packed = false;
        for (size_t at = 0; at + 8 <= data.size(); ++at) {
            int64_t n;
            std::memcpy(&n, &data[at], 8);
            if (n != 0 && uint64_t(n < 0 ? -n : n) == data.size() - at - 8) {
                word = at;
                packed = n > 0;
            }
        }
        {
            VdbFileReader reader(good);
            openvdb::GridBase::Ptr read;
            ASSERT_NO_THROW(read = reader.readGrid("density"));
            EXPECT_EQ(read->metaValue<std::string>("file_compression"),
                      compression & io::COMPRESS_BLOSC ? "blosc + active values" : "zip + active values");
        }
        ASSERT_NE(word, std::string::npos);
        struct Damage {
            const char* name;
            size_t at;
            int64_t value;
            int width;
        };
        std::vector<Damage> damages = {
            {"an uncompressed block larger than the leaf (the fuzz finding)", word, -(512 * 4 + 8182), 8},
            {"an uncompressed block smaller than the leaf", word, -100, 8},
            {"a block beyond the end of the file", word, int64_t(1) << 40, 8},
            {"the most negative size", word, std::numeric_limits<int64_t>::min(), 8},
        };
        EXPECT_TRUE(packed || !(compression & io::COMPRESS_BLOSC));
        if ((compression & io::COMPRESS_BLOSC) && packed) {
            damages.push_back({"Blosc's uncompressed size larger than the leaf", word + 8 + 4, 512 * 4 + 8182, 4});
            damages.push_back({"Blosc's compressed size beyond the block", word + 8 + 12, 1 << 20, 4});
        }
        for (const Damage& d : damages) {
            SCOPED_TRACE(std::string(compression & io::COMPRESS_BLOSC ? "blosc: " : "zip: ") + d.name);
            std::string bad = data;
            std::memcpy(&bad[d.at], &d.value, d.width);
            const std::string path = dir / "bad.vdb";
            writeText(path, bad);
            const std::string message = readError(path, "density");
            EXPECT_NE(message.find("grid 'density'"), std::string::npos) << message;
            EXPECT_NE(message.find("block"), std::string::npos) << message;
            EXPECT_NE(message.find("(damaged)"), std::string::npos) << message;
            // Through the loader: one line naming the key and the file.
            const std::string input = inputError(vdbScene(path));
            EXPECT_NE(input.find("volumes[0].source.grids.density"), std::string::npos) << input;
            EXPECT_NE(input.find(path), std::string::npos) << input;
            EXPECT_EQ(input.find('\n'), std::string::npos) << input;
        }
    }
}

// A grid 'density' of background `background` with two root tiles, an active one of value `a` at
// x = -4096 and an inactive one of value `b` at x = 4096, written uncompressed to `path`; checks
// that it reads, and returns the file's bytes.
template <class GridT>
std::string twoRootTilesUncompressed(const std::string& path, typename GridT::ValueType background,
                                     typename GridT::ValueType a, typename GridT::ValueType b)
{
    typename GridT::Ptr grid = GridT::create(background);
    grid->setName("density");
    grid->tree().addTile(3, Coord(-4096, 0, 0), a, true);
    grid->tree().addTile(3, Coord(4096, 0, 0), b, false);
    {
        openvdb::io::File file(path);
        file.setCompression(openvdb::io::COMPRESS_NONE);
        file.write({grid});
    }
    EXPECT_EQ(readError(path, "density"), "");
    return readBytes(path);
}

// Fuzz bug 5 (docs/robustness.md): RootNode::readTopology reads a root tile's active flag
// straight into a bool, so a byte other than 0 or 1 is undefined behaviour in OpenVDB (UBSan:
// "not a valid value for type 'bool'"). VdbFileReader's topology walk refuses it first.
TEST(VdbFileReader, RootTileActiveFlagOtherThan0Or1IsRefused)
{
    openvdb::initialize();
    ScratchDir dir;
    const std::string good = dir / "good.vdb";
    const std::string data = twoRootTilesUncompressed<openvdb::Int32Grid>(good, 0, 77, 78);
    // The second tile (in file order, by origin): origin, value, active flag.
    const int32_t tile[4] = {4096, 0, 0, 78};
    const size_t at = data.find(std::string(reinterpret_cast<const char*>(tile), sizeof tile));
    ASSERT_NE(at, std::string::npos);
    ASSERT_EQ(data.at(at + sizeof tile), '\0');
    for (unsigned char flag : {2, 0x80, 0xff}) {
        std::string bad = data;
        bad[at + sizeof tile] = char(flag);
        const std::string path = dir / "bad.vdb";
        writeText(path, bad);
        const std::string message = readError(path, "density");
        char hex[8];
        std::snprintf(hex, sizeof hex, "0x%02X", flag);
        EXPECT_NE(message.find("grid 'density'"), std::string::npos) << message;
        EXPECT_NE(message.find(std::string("root tile 1's active flag is byte ") + hex + ", not 0 or 1"),
                  std::string::npos)
            << message;
        EXPECT_NE(message.find("(damaged)"), std::string::npos) << message;
        const std::string input = inputError(vdbScene(path));
        EXPECT_NE(input.find(path), std::string::npos) << input;
        EXPECT_EQ(input.find('\n'), std::string::npos) << input;
    }
}

// The same for the other bytes OpenVDB reads straight into a bool: a bool tree's background and
// its tiles' values (and, stored uncompressed, its internal nodes' values). Each damaged in turn
// in an uncompressed BoolGrid file is refused with the byte named; the intact file reads.
TEST(VdbFileReader, BoolTreeValuesOtherThan0Or1AreRefused)
{
    openvdb::initialize();
    ScratchDir dir;
    const std::string good = dir / "good.vdb";
    const std::string data = twoRootTilesUncompressed<openvdb::BoolGrid>(good, false, true, true);
    // The root's header: buffer count 1, the background (false), 2 tiles, 0 children.
    const char header[13] = {1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0};
    const size_t background = data.find(std::string(header, sizeof header));
    ASSERT_NE(background, std::string::npos);
    // The second tile (in file order, by origin): origin, value (true), active flag (false).
    const int32_t origin[3] = {4096, 0, 0};
    const size_t tile = data.find(std::string(reinterpret_cast<const char*>(origin), sizeof origin));
    ASSERT_NE(tile, std::string::npos);
    ASSERT_EQ(data.at(tile + sizeof origin), '\1');
    ASSERT_EQ(data.at(tile + sizeof origin + 1), '\0');
    const struct {
        size_t at;
        const char* named;
    } damages[] = {{background + 4, "the background is byte 0x30"},
                   {tile + sizeof origin, "root tile 1's value is byte 0x30"},
                   {tile + sizeof origin + 1, "root tile 1's active flag is byte 0x30"}};
    for (const auto& d : damages) {
        std::string bad = data;
        bad[d.at] = '0';  // 0x30
        const std::string path = dir / "bad.vdb";
        writeText(path, bad);
        const std::string message = readError(path, "density");
        EXPECT_NE(message.find(std::string(d.named) + ", not 0 or 1"), std::string::npos) << message;
        EXPECT_NE(message.find("(damaged)"), std::string::npos) << message;
    }
}

// The values of a bool tree's internal nodes are bools too, and stored compressed where the file
// is: VdbFileReader unpacks such a block and checks its bytes before OpenVDB reads them into bools.
// A BoolGrid with one tile (true) in its level-2 node, written with ZIP and with Blosc: the
// level-2 node's 32768 values are one block, whose byte for the tile is changed from 1 to 2 and
// packed again (padded to the block's length: both codecs stop at their stream's own end). The
// file is refused with the byte named; the intact one reads.
TEST(VdbFileReader, CompressedBoolNodeValuesOtherThan0Or1AreRefused)
{
    openvdb::initialize();
    namespace io = openvdb::io;
    ScratchDir dir;
    constexpr size_t kValues = 32768;  // a level-2 node's
    for (uint32_t compression : {uint32_t(io::COMPRESS_ZIP), uint32_t(io::COMPRESS_BLOSC)}) {
        const bool blosc = compression == io::COMPRESS_BLOSC;
        SCOPED_TRACE(blosc ? "blosc" : "zip");
        openvdb::BoolGrid::Ptr grid = openvdb::BoolGrid::create(false);
        grid->setName("density");
        grid->tree().addTile(2, Coord(0, 0, 0), true, true);  // a 128^3 tile of the level-2 node
        const std::string good = dir / "good.vdb";
        {
            io::File file(good);
            file.setCompression(compression);
            file.write({grid});
        }
        ASSERT_EQ(readError(good, "density"), "");
        const std::string data = readBytes(good);
        // The block: a length n (int64), then n bytes that unpack to kValues bools, one of them 1.
        size_t at = std::string::npos;
        int64_t n = 0;
        std::vector<unsigned char> values(kValues);
        for (size_t i = 0; i + 8 + 16 < data.size() && at == std::string::npos; ++i) {
            std::memcpy(&n, &data[i], sizeof n);
            if (n < 16 || n > 4096 || i + 8 + size_t(n) > data.size())
                continue;
            const auto* src = reinterpret_cast<const unsigned char*>(&data[i + 8]);
            bool unpacked = false;
            if (blosc) {
                uint32_t nbytes, cbytes;  // Blosc's header: its sizes, checked before it unpacks
                std::memcpy(&nbytes, src + 4, 4);
                std::memcpy(&cbytes, src + 12, 4);
                unpacked = nbytes == kValues && cbytes == uint32_t(n) &&
                           blosc_decompress(src, values.data(), kValues) == int(kValues);
            } else {
                uLongf length = kValues;
                unpacked = uncompress(values.data(), &length, src, uLong(n)) == Z_OK && length == kValues;
            }
            if (unpacked && values[0] == 1 && std::count(values.begin(), values.end(), 0) == long(kValues - 1))
                at = i;
        }
        ASSERT_NE(at, std::string::npos) << "no block of the level-2 node's values";
        values[0] = 2;
        std::vector<unsigned char> packed(kValues + 64, 0);
        size_t length = 0;
        if (blosc) {
            const int r = blosc_compress_ctx(9, BLOSC_SHUFFLE, 1, kValues, values.data(), packed.data(), packed.size(),
                                             BLOSC_LZ4_COMPNAME, 0, 1);
            ASSERT_GT(r, 0);
            length = size_t(r);
        } else {
            uLongf out = uLongf(packed.size());
            ASSERT_EQ(compress2(packed.data(), &out, values.data(), kValues, Z_BEST_COMPRESSION), Z_OK);
            length = size_t(out);
        }
        ASSERT_LE(length, size_t(n)) << "packed again, the block would not fit its place";
        std::string bad = data;
        std::memcpy(&bad[at + 8], packed.data(), size_t(n));  // the rest of n: zeros past the stream's end
        const std::string path = dir / "bad.vdb";
        writeText(path, bad);
        const std::string message = readError(path, "density");
        EXPECT_NE(message.find("a node value (0 of 32768 in a compressed block) is byte 0x02, not 0 or 1"),
                  std::string::npos)
            << message;
        EXPECT_NE(message.find("(damaged)"), std::string::npos) << message;
    }
}

// Issue 18, item 5: OpenVDB reads a metadata value by its type, not by the size word before it
// (a fixed-size type reads its own size; the delayed-load table walks counts of its own and
// allocates them first). A fuzzed file whose 'file_bbox_max' said type 'int32' with 12 bytes
// passed the length checks, then OpenVDB read 4 bytes and took a name's characters for a 1.8 GB
// string length. VdbFileReader now walks each value as OpenVDB reads it.
TEST(VdbFileReader, MetadataValuesAreCheckedAsOpenVdbReadsThem)
{
    openvdb::initialize();
    ScratchDir dir;
    FloatGrid::Ptr grid = floatGrid("density");
    for (int i = 0; i < 3000; ++i)  // 3000 leaves: a delayed-load table Blosc compresses
        grid->tree().setValueOn(Coord(8 * (i % 50), 8 * (i / 50), 0), 1.0f);
    const std::string good = dir / "good.vdb";
    {
        openvdb::io::File file(good);
        file.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
        file.write({grid});
    }
    const std::string data = readBytes(good);
    {
        VdbFileReader reader(good);
        openvdb::GridBase::Ptr read = reader.readGrid("density");
        EXPECT_EQ(openvdb::gridPtrCast<FloatGrid>(read)->tree().leafCount(), 3000u);
    }
    for (int leaves : {1, 50, 110, 200}) {  // tables OpenVDB stores raw, or pads to 128 bytes and packs
        FloatGrid::Ptr small = floatGrid("density");
        for (int i = 0; i < leaves; ++i)
            small->tree().setValueOn(Coord(8 * i, 0, 0), 1.0f);
        const std::string path = dir / "small.vdb";
        openvdb::io::File file(path);
        file.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
        file.write({small});
        file.close();
        VdbFileReader reader(path);
        openvdb::GridBase::Ptr read;
        ASSERT_NO_THROW(read = reader.readGrid("density")) << leaves;
        EXPECT_EQ(openvdb::gridPtrCast<FloatGrid>(read)->tree().leafCount(), openvdb::Index64(leaves));
    }
    auto u32 = [&](size_t at) {
        uint32_t v;
        std::memcpy(&v, &data[at], 4);
        return v;
    };
    // The table: its type name, its size word, then a leaf count, the mask's Blosc block and the
    // leaf sizes' Blosc block (Blosc's header: the unpacked size at byte 4).
    const size_t type = data.find("__delayedload");
    ASSERT_NE(type, std::string::npos);
    const size_t table = type + 13 + 4;
    ASSERT_EQ(u32(table), 3000u);
    const size_t mask = table + 4;
    ASSERT_GT(u32(mask), 16u);  // compressed
    ASSERT_EQ(u32(mask + 4 + 4), 3000u);
    const size_t sizes = mask + 4 + u32(mask);
    ASSERT_GT(u32(sizes), 16u);
    ASSERT_NE(u32(sizes), 0xffffffffu);
    ASSERT_EQ(u32(sizes + 4 + 4), 3000u * 8);
    const size_t bboxType = data.find("vec3i", data.find("file_bbox_max"));
    ASSERT_NE(bboxType, std::string::npos);
    struct Damage {
        const char* name;
        size_t at;
        std::string bytes;
        const char* expect;
    };
    auto word = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
    const std::vector<Damage> damages = {
        {"the fuzz finding: a vec3i renamed int32", bboxType, "int32",
         "its metadata 'file_bbox_max' of type 'int32' claims 12 bytes; the type holds 4 bytes"},
        {"a leaf count of 2^32 - 1", table, word(0xffffffffu), "4294967295 leaves, more than"},
        {"one leaf more than the mask holds", table, word(3001), "leaf mask is a Blosc block"},
        {"the mask's block past the table", mask, word(1u << 20), "leaf mask is a Blosc block of 1048576 bytes"},
        {"the sizes unpacking to 1 GiB", sizes + 8, word(1u << 30), "leaf sizes is a Blosc block"},
        {"a raw mask past the table", mask, word(0), "leaf mask (3000 bytes) runs past"},
    };
    for (const Damage& d : damages) {
        SCOPED_TRACE(d.name);
        std::string bad = data;
        bad.replace(d.at, d.bytes.size(), d.bytes);
        const std::string path = dir / "bad.vdb";
        writeText(path, bad);
        const std::string message = readError(path, "density");
        EXPECT_NE(message.find("grid 'density'"), std::string::npos) << message;
        EXPECT_NE(message.find(d.expect), std::string::npos) << message;
        EXPECT_NE(message.find("(damaged)"), std::string::npos) << message;
        const std::string input = inputError(vdbScene(path));
        EXPECT_NE(input.find("volumes[0].source.grids.density"), std::string::npos) << input;
        EXPECT_EQ(input.find('\n'), std::string::npos) << input;
    }
}

// fuzz_vdb (10^6 run, 2026-12-03): a density grid whose affine map stretched one index axis to
// 3.1e175 m (finite, non-singular) passed the transform check, then OpenVDB's resampling of the
// file's second grid onto it threw ArithmeticError (exit 1). An axis outside [1e-30, 1e30] m is
// bad input; a resampling OpenVDB refuses is too.
TEST(VdbLoad, TransformAxesBeyondFloatAreAnInputError)
{
    ScratchDir dir;
    for (double length : {3.1e175, 1e31}) {  // (OpenVDB will not write a map nearly singular)
        const std::string path = dir / "axis.vdb";
        FloatGrid::Ptr grid = FloatGrid::create(0.0f);
        grid->setName("density");
        openvdb::Mat4d m = openvdb::Mat4d::identity();
        m.setRow(0, openvdb::Vec4d(0.1, 0.05, 0, 0));
        m.setRow(1, openvdb::Vec4d(0, length, 0, 0));
        m.setRow(2, openvdb::Vec4d(0, 0, 0.1, 0));
        grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
        grid->tree().setValue(Coord(0, 0, 0), 1.0f);
        writeVdb(path, {grid});
        const std::string message = inputError(vdbScene(path));
        EXPECT_NE(message.find("volumes[0].source.grids.density"), std::string::npos) << length << ": " << message;
        EXPECT_NE(message.find("index axis 1"), std::string::npos) << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
}

// Resampling a role grid onto the density's voxels walks every value it covers there, so a role
// grid too large for the bricks is refused before the walk (a 20 KB fuzzed file with one active
// tile of 4096^3 voxels resampled for hours: tests/fuzz/regressions/vdb). Both measures count: the
// role grid's own active voxels (a 4096^3 tile at the density's voxel size, 6.9e10), and its
// walked nodes on the density's voxels: 128^3 voxels of 1 m over a density of 0.01 m voxels, 2e12;
// and one active voxel of 0.1 m over a density of 0.1 mm voxels, whose leaf the bound counts
// whole (OpenVDB's resampler walked it whole): 8000^3 = 5.1e11 density voxels, though the voxel's
// own 1000^3 pass the bound (a hang: no answer within 40 s from the release CLI before the walk
// was counted; refused in 0.18 s now).
TEST(VdbLoad, RoleGridTooLargeToResampleIsRefusedBeforeTheWalk)
{
    ScratchDir dir;
    struct Case {
        double densityVoxel, roleVoxel;
        int n;  // the role grid's active voxels: n^3 from the origin
    } cases[] = {{0.01, 0.0125, 4096}, {0.01, 1.0, 128}, {1e-4, 0.1, 1}};
    for (const Case& c : cases) {
        FloatGrid::Ptr d = floatGrid("density", c.densityVoxel), t = floatGrid("temperature", c.roleVoxel);
        d->tree().fill(CoordBBox(Coord(0), Coord(15)), 1.0f, true);
        t->tree().fill(CoordBBox(Coord(0), Coord(c.n - 1)), 1500.0f, true);
        const std::string path = dir / "role.vdb";
        writeVdb(path, {d, t});
        const auto start = std::chrono::steady_clock::now();
        const std::string message = inputError(vdbScene(path));
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_NE(message.find("volumes[0].source.grids.temperature: grid 'temperature' in '" + path + "'"),
                  std::string::npos)
            << message;
        EXPECT_NE(message.find("voxels nimbus resamples onto the density grid"), std::string::npos) << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
        EXPECT_LT(seconds, 10.0) << "refused before the walk";
    }
}

// Cancel within a second (issue 18, item 3) reaches into the volumes' load, which comes before
// the render context: buildVolumes polls the render's StopFlag in the generators' blocks and in
// OpenVDB's resampling walk, and throws Cancelled. Measured from the raise to the throw; each
// load takes many seconds when nobody stops it (the cloud ~13 s on this 2-core machine, the
// resampling of a 256^3 tile onto finer voxels and its shading ~5 s).
TEST(VdbLoad, CancelEndsTheLoadWithinASecond)
{
    ScratchDir dir;
    FloatGrid::Ptr d = floatGrid("density", 0.01), t = floatGrid("temperature", 0.0125);
    d->tree().fill(CoordBBox(Coord(0), Coord(15)), 1.0f, true);
    t->tree().fill(CoordBBox(Coord(0), Coord(255)), 1500.0f, true);
    const std::string path = dir / "role.vdb";
    writeVdb(path, {d, t});
    struct Case {
        const char* what;
        Scene scene;
    } cases[] = {{"a procedural cloud of 1.8e7 voxels", proceduralScene("cloud", {{"voxel_size", 0.01}})},
                 {"a role grid resampled onto the density's voxels", vdbScene(path)}};
    for (const Case& c : cases) {
        const std::optional<double> after =
            secondsToCancel([&](const StopFlag* stop) { buildVolumes(c.scene, nullptr, stop); }, 300);
        ASSERT_TRUE(after) << c.what << ": the load ended before the cancel at 0.3 s";
        EXPECT_LT(*after, 1.0) << c.what;
        printf("cancel of %s: %.3f s after the raise\n", c.what, *after);
    }
}

// fuzz_vdb (2026-12-05, session 25): a map's inverse is stored beside it in the file (here a
// UniformScaleMap's reciprocal scale), and OpenVDB's worldToIndex uses the stored copy. A file
// whose copy disagrees placed voxels by one transform and looked them up by another; its role
// grid resampled into 17 GB (tests/fuzz/regressions/vdb/transform_inverse_damaged_resample_17gb.vdb).
TEST(VdbLoad, TransformWhoseStoredInverseDisagreesIsRefused)
{
    ScratchDir dir;
    const std::string path = dir / "inverse.vdb";
    FloatGrid::Ptr grid = floatGrid("density", 0.125);
    grid->tree().setValue(Coord(0, 0, 0), 1.0f);
    writeVdb(path, {grid});
    ASSERT_EQ(damageUniformScale(path, 0.125, 0.5), 3);  // the scale factors, not their stored reciprocals
    const std::string message = inputError(vdbScene(path));
    EXPECT_NE(message.find("volumes[0].source.grids.density: grid 'density' in '" + path +
                           "' has a transform whose stored inverse does not invert it (damaged)"),
              std::string::npos)
        << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

// Memory known before it is spent (issue 18, item 4), in the load: a role grid resampled onto a
// density grid of much finer voxels along one axis fills every leaf its mapped box touches. 9^3
// temperatures of 0.1 m over densities of 1 mm by 0.1 m by 0.1 m voxels reach 10 temperature
// voxels along each axis (the box sampler reads voxel v within (v - 1, v + 1)): a box of 1003 x 13
// x 13 density voxels (one more each side for the rounding) in 126 x 3 x 3 = 1134 leaves, 7.6 MiB
// with their bricks and a copy. Under a
// render.memory_limit of 1 MB it is refused before the walk, naming the grid and the key; under
// 1 GB it loads.
TEST(VdbLoad, RoleGridResampledPastTheMemoryLimitIsRefusedBeforeTheWalk)
{
    ScratchDir dir;
    FloatGrid::Ptr d = floatGrid("density", 0.1), t = floatGrid("temperature", 0.1);
    openvdb::math::Transform::Ptr thin = openvdb::math::Transform::createLinearTransform(1.0);
    thin->preScale(openvdb::Vec3d(0.001, 0.1, 0.1));
    d->setTransform(thin);
    d->tree().fill(CoordBBox(Coord(0), Coord(799, 7, 7)), 1.0f, true);
    t->tree().fill(CoordBBox(Coord(0), Coord(8)), 1500.0f, true);
    const std::string path = dir / "thin.vdb";
    writeVdb(path, {d, t});
    Scene scene = vdbScene(path);
    scene.render.memoryLimit = 1e6f;
    const std::string message = inputError(scene);
    EXPECT_NE(message.find("volumes[0].source.grids.temperature: grid 'temperature' in '" + path +
                           "': resampling it onto the density grid's voxels would take about"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("(1.13e+03 leaves of 8^3 voxels"), std::string::npos) << message;
    EXPECT_NE(message.find("raise render.memory_limit"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    scene.render.memoryLimit = 1e9f;
    EXPECT_NO_THROW(buildVolumes(scene));
}

// The shader's run is bounded before it starts (issue 18, item 4): AX may stream every active
// tile to voxels, so the grids' active voxels, tiles counted, times 16 bytes (a density and an
// emission voxel) may not pass render.memory_limit. A density of one active tile of 128^3 voxels
// (2.1e6, 32 MiB at that rate) beside a temperature: refused under 16 MiB naming the source, loaded
// under 1 GB. (A fuzzed file's density of 365 such tiles ran the default shader for 40 s to a
// 1.8 GB peak under a 64 MiB limit: tests/fuzz/regressions/nvdb/zero_density_tiles_*.)
TEST(VdbLoad, ShaderRunPastTheMemoryLimitIsRefusedBeforeItStarts)
{
    ScratchDir dir;
    FloatGrid::Ptr d = floatGrid("density", 0.1), t = floatGrid("temperature", 0.1);
    d->tree().addTile(2, Coord(0), 0.5f, true);  // a tile of a lower internal node: 128^3 voxels
    t->tree().fill(CoordBBox(Coord(0), Coord(7)), 1500.0f, true);
    const std::string path = dir / "tiles.vdb";
    writeVdb(path, {d, t});
    Scene scene = vdbScene(path);
    scene.render.memoryLimit = 16.0f * 1024 * 1024;
    const std::string message = inputError(scene);
    EXPECT_EQ(message.rfind("scene.json: volumes[0].source: the default (emission) shader on the grids of '" + path +
                                "' would run over 2.1e+06 active voxels",
                            0),
              0u)
        << message;
    EXPECT_NE(message.find("more than render.memory_limit (16.0 MiB)"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    scene.render.memoryLimit = 1e9f;
    auto v = buildOne(scene);
    EXPECT_TRUE(v->hasEmission());
}

// The brick pool is checked against render.memory_limit before it is allocated (issue 18, item 4):
// a density of one active tile of 128^3 voxels of 0.5 fills 17^3 bricks (the tile's 16^3 and the
// apron layer below it) of 9^3 floats, 13.7 MiB with the table: refused under 12 MiB naming the
// grid, its file and the key (under 8 MiB by the floor of its own bricks), loaded under 1 GB. (A fuzzed file's density of active tiles filled 4.9 GB
// of bricks under a 64 MiB limit: tests/fuzz/regressions/nvdb/active_tiles_fill_gigabytes_of_bricks.nvdb.)
TEST(VdbLoad, BrickPoolPastTheMemoryLimitIsRefusedBeforeItIsAllocated)
{
    ScratchDir dir;
    FloatGrid::Ptr d = floatGrid("density", 0.1);
    d->tree().addTile(2, Coord(0), 0.5f, true);  // a tile of a lower internal node: 128^3 voxels
    const std::string path = dir / "tile.vdb";
    writeVdb(path, {d});
    Scene scene = vdbScene(path);
    scene.render.memoryLimit = 12.0f * 1024 * 1024;
    EXPECT_EQ(inputError(scene), "scene.json: volumes[0].source.grids.density: grid 'density' in '" + path +
                                     "': 4913 bricks of 8^3 voxels are active, 13.7 MiB with their table, more than "
                                     "render.memory_limit (12.0 MiB); raise render.memory_limit");
    // Under the floor (the tile's own 16^3 bricks, 11.4 MiB: before the apron's are listed and
    // sorted) it is refused at once.
    scene.render.memoryLimit = 8.0f * 1024 * 1024;
    EXPECT_EQ(inputError(scene), "scene.json: volumes[0].source.grids.density: grid 'density' in '" + path +
                                     "': at least 4096 bricks of 8^3 voxels are active, 11.4 MiB or more with their "
                                     "table, more than render.memory_limit (8.0 MiB); raise render.memory_limit");
    scene.render.memoryLimit = 1e9f;
    auto v = buildOne(scene);
    EXPECT_EQ(densityAt(*v, make_float3(6.4f, 6.4f, 6.4f)), 0.5f);
}

// OpenVDB's resampler walks every leaf node and every tile not of the background, active or not
// (a fuzzed file's temperature grid had no active value and one inactive leaf near the int limit,
// whose corners mapped onto the density's voxels overflowed the sampler's cast to int:
// tests/fuzz/regressions/vdb/role_grid_inactive_leaf_near_int_limit_ubsan.vdb). nimbus reads a
// role grid's active values only, so its inactive nodes are not walked: an inactive leaf at
// INT_MAX - 20 and an inactive tile of 4096^3 voxels of 1500 K (5.5e11 density voxels, hours of
// walking) beside 8^3 active temperatures load in seconds, the active ones emitting as before; a
// temperature grid with only those inactive nodes loads as no temperature at all.
TEST(VdbLoad, RoleGridNodesWithNoActiveValueAreNotWalked)
{
    ScratchDir dir;
    for (bool anyActive : {true, false}) {
        FloatGrid::Ptr d = floatGrid("density", 0.5), t = floatGrid("temperature", 1.0);
        d->tree().fill(CoordBBox(Coord(0), Coord(31)), 1.0f, true);
        if (anyActive)
            t->tree().fill(CoordBBox(Coord(0), Coord(7)), 2000.0f, true);  // world [0, 7]
        t->tree().setValueOff(Coord(std::numeric_limits<int>::max() - 20, 0, 0), 3000.0f);
        t->tree().fill(CoordBBox(Coord(-8192, 0, 0), Coord(-4097, 4095, 4095)), 1500.0f, false);
        ASSERT_EQ(t->tree().activeVoxelCount(), anyActive ? 512u : 0u);
        const std::string path = dir / "inactive.vdb";
        writeVdb(path, {d, t});
        const auto start = std::chrono::steady_clock::now();
        auto v = buildOne(vdbScene(path, {}, "blackbody"));
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_LT(seconds, 10.0);
        if (anyActive)
            EXPECT_GT(emissionAt(*v, make_float3(3, 3, 3)).x, 10.0f);
        else
            EXPECT_EQ(emissionAt(*v, make_float3(3, 3, 3)).x, 0.0f);
        EXPECT_EQ(emissionAt(*v, make_float3(12, 12, 12)).x, 0.0f);
    }
}

// The resampler computes in int index coordinates: a role grid whose active values lie past
// +-2^30 on its own voxels (2^30 + 100), or reach past it mapped onto the density's (6e8 voxels of
// 1 m onto 0.5 m voxels: 1.2e9), is refused before the walk, naming the grid and the key.
TEST(VdbLoad, RoleGridReachingPastTwoToTheThirtyIsRefused)
{
    ScratchDir dir;
    for (int x : {(1 << 30) + 100, 600000000}) {
        FloatGrid::Ptr d = floatGrid("density", 0.5), t = floatGrid("temperature", 1.0);
        d->tree().fill(CoordBBox(Coord(0), Coord(31)), 1.0f, true);
        t->tree().fill(CoordBBox(Coord(x, 0, 0), Coord(x + 3, 3, 3)), 2000.0f, true);  // a small box, far out
        const std::string path = dir / "far.vdb";
        writeVdb(path, {d, t});
        const std::string message = inputError(vdbScene(path, {}, "blackbody"));
        EXPECT_NE(message.find("volumes[0].source.grids.temperature: grid 'temperature' in '" + path +
                               "': its active values reach index"),
                  std::string::npos)
            << message;
        EXPECT_NE(message.find("past the +-2^30 nimbus resamples in"), std::string::npos) << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
}

// A role grid's inactive values are the background, also inside a leaf with active ones: the
// resampled grid holds nothing where no active value reaches, so the shader reads 0 there and the
// resampling's memory is that of the mapped active box. Temperatures of 0.2 m voxels over
// densities of 0.1 m: 2000 K active at indices 0-3, 3000 K inactive at 4-7 of the same leaf; at
// x = 1.2 m (index 6) the default shader emits nothing, at 0.3 m it emits.
TEST(VdbLoad, InactiveVoxelsOfARoleGridReadAsTheBackground)
{
    ScratchDir dir;
    FloatGrid::Ptr d = floatGrid("density", 0.1), t = floatGrid("temperature", 0.2);
    d->tree().fill(CoordBBox(Coord(0), Coord(31)), 1.0f, true);
    t->tree().fill(CoordBBox(Coord(0), Coord(3, 7, 7)), 2000.0f, true);
    t->tree().fill(CoordBBox(Coord(4, 0, 0), Coord(7, 7, 7)), 3000.0f, false);
    ASSERT_EQ(t->tree().leafCount(), 1u);
    const std::string path = dir / "inactive_voxels.vdb";
    writeVdb(path, {d, t});
    auto v = buildOne(vdbScene(path));
    EXPECT_GT(emissionAt(*v, make_float3(0.3f, 0.7f, 0.7f)).x, 10.0f);
    EXPECT_EQ(emissionAt(*v, make_float3(1.2f, 0.7f, 0.7f)).x, 0.0f);
}
