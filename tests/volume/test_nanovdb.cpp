// NanoVDB files (.nvdb) as `vdb` sources (issue 17, item 10): the same grids written as .vdb by
// OpenVDB and as .nvdb by NanoVDB (openToNanoVDB, the way nanovdb_convert makes them) build the
// same volume bit for bit and render the same image; an .nvdb's errors are those of a .vdb.
#include "../render/SceneBuilders.h"
#include "VolumeTestUtil.h"
#include "engine/Renderer.h"
#include "volume/Procedural.h"

#define NANOVDB_USE_ZIP
#define NANOVDB_USE_BLOSC
#include <nanovdb/util/IO.h>
#include <nanovdb/util/OpenToNanoVDB.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cstddef>
#include <fstream>

using namespace nimbus;
using namespace nimbus::test;
using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;

namespace {

// A procedural cloud (density), a temperature grid over part of it (emission through the default
// shader), a flame grid and a swirling velocity grid, on the cloud's voxels.
openvdb::GridPtrVec fireGrids()
{
    openvdb::initialize();
    VolumeSource source;
    source.type = SourceType::Procedural;
    source.generator = "cloud";
    source.params = {{"voxel_size", 0.05}};
    auto cloud = makeProceduralGrid(source, "test");
    FloatGrid::Ptr density = FloatGrid::create(0.0f);
    density->setTree(std::make_shared<openvdb::FloatTree>(cloud->tree()));
    density->setTransform(cloud->transform().copy());
    density->setName("density");
    density->setGridClass(openvdb::GRID_FOG_VOLUME);
    FloatGrid::Ptr temperature = FloatGrid::create(0.0f), flame = FloatGrid::create(0.0f);
    openvdb::Vec3SGrid::Ptr vel = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    for (auto* g : {temperature.get(), flame.get()})
        g->setTransform(cloud->transform().copy());
    vel->setTransform(cloud->transform().copy());
    temperature->setName("temperature");
    flame->setName("flame");
    vel->setName("vel");
    for (auto it = density->cbeginValueOn(); it; ++it) {
        openvdb::CoordBBox box;
        it.getBoundingBox(box);
        for (auto c = box.begin(); c; ++c) {
            const Coord& p = *c;
            if (p.y() < -4)
                temperature->tree().setValue(p, 1200.0f + 40.0f * float((p.x() * 7 + p.z() * 3) & 15));
            if (p.y() < -8)
                flame->tree().setValue(p, 0.25f + 0.05f * float(p.z() & 7));
            vel->tree().setValue(p, openvdb::Vec3s(-0.1f * float(p.z()), 0.05f, 0.1f * float(p.x())) * 0.02f);
        }
    }
    return {density, temperature, flame, vel};
}

void writeVdb(const std::string& path, const openvdb::GridPtrVec& grids)
{
    openvdb::io::File(path).write(grids);
}

void writeNvdb(const std::string& path, const openvdb::GridPtrVec& grids,
               nanovdb::io::Codec codec = nanovdb::io::Codec::NONE)
{
    std::vector<nanovdb::GridHandle<nanovdb::HostBuffer>> handles;
    for (const auto& g : grids)
        handles.push_back(nanovdb::openToNanoVDB(g));
    nanovdb::io::writeGrids(path, handles, codec);
}

void expectSameGrid(const BrickGrid& a, const BrickGrid& b, const char* what)
{
    EXPECT_EQ(a.brickCount(), b.brickCount()) << what;
    EXPECT_EQ(a.table(), b.table()) << what;
    EXPECT_EQ(a.pool(), b.pool()) << what;  // every value, bit for bit
    EXPECT_EQ(a.majorants(), b.majorants()) << what;
}

Scene fireScene(const std::string& file, Method method)
{
    Scene s = emptyScene(48, 40);
    s.volumes.push_back(vdbScene(file).volumes[0]);
    s.volumes[0].medium.sigma_s = splat(6.0f);
    s.volumes[0].medium.sigma_a = splat(0.3f);
    s.lights.push_back(distantLight("sun", make_float3(0.4f, -1.0f, -0.3f), splat(3.0f)));
    s.camera.from = make_float3(0.3f, 0.4f, 4.5f);
    s.camera.to = make_float3(0, 0, 0);
    s.render.method = method;
    s.render.spp = 2;
    return s;
}

}  // namespace

TEST(NanoVdb, SameGridsAsTheVdbBitForBit)
{
    ScratchDir dir;
    const openvdb::GridPtrVec grids = fireGrids();
    writeVdb(dir / "fire.vdb", grids);
    writeNvdb(dir / "fire.nvdb", grids);
    writeNvdb(dir / "fire_zip.nvdb", grids, nanovdb::io::Codec::ZIP);
    writeNvdb(dir / "fire_blosc.nvdb", grids, nanovdb::io::Codec::BLOSC);
    Scene vdb = vdbScene(dir / "fire.vdb");
    vdb.volumes[0].medium.velocityScale = 1.0f;  // reads vel too
    auto a = buildOne(vdb);
    ASSERT_TRUE(a->hasEmission());
    ASSERT_FALSE(a->velocity.empty());
    EXPECT_EQ(a->gridsRead, (std::vector<std::string>{"density", "temperature", "flame", "vel"}));
    for (const char* name : {"fire.nvdb", "fire_zip.nvdb", "fire_blosc.nvdb", "FIRE_UPPER.NVDB"}) {
        SCOPED_TRACE(name);
        if (std::string(name) == "FIRE_UPPER.NVDB")
            std::filesystem::copy_file(dir / "fire.nvdb", dir / name);
        Scene nvdb = vdb;
        nvdb.volumes[0].source.file = dir / name;
        auto b = buildOne(nvdb);
        EXPECT_EQ(b->gridsRead, a->gridsRead);
        expectSameGrid(a->density, b->density, "density");
        expectSameGrid(a->emission, b->emission, "emission");
        expectSameGrid(a->velocity, b->velocity, "velocity");
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                EXPECT_EQ(a->indexFromWorld.at(r, c), b->indexFromWorld.at(r, c));
        EXPECT_EQ(a->voxelSize, b->voxelSize);
    }
}

TEST(NanoVdb, RendersTheSameImageAsTheVdb)
{
    ScratchDir dir;
    const openvdb::GridPtrVec grids = fireGrids();
    writeVdb(dir / "fire.vdb", grids);
    writeNvdb(dir / "fire.nvdb", grids);
    for (Method method : {Method::Single, Method::Wkb}) {
        RenderResult a = render(fireScene(dir / "fire.vdb", method));
        RenderResult b = render(fireScene(dir / "fire.nvdb", method));
        const Aov* pa = a.film.find("beauty");
        const Aov* pb = b.film.find("beauty");
        ASSERT_TRUE(pa && pb);
        double sum = 0;
        for (float v : pa->pixels)
            sum += v;
        EXPECT_GT(sum, 0.0) << "the cloud is in view and lit";
        EXPECT_EQ(pa->pixels, pb->pixels) << "method " << int(method);
    }
}

TEST(NanoVdb, ErrorsAreThoseOfAVdbFile)
{
    ScratchDir dir;
    EXPECT_EQ(inputError(vdbScene("/x/cloud.nvdb")),
              "scene.json: volumes[0].source.file: cannot open '/x/cloud.nvdb': no such file");

    openvdb::initialize();
    FloatGrid::Ptr d = FloatGrid::create(0.0f), t = FloatGrid::create(0.0f);
    d->setName("density");
    t->setName("temperature");
    d->tree().setValue(Coord(0), 1.0f);
    t->tree().setValue(Coord(0), 1000.0f);
    writeNvdb(dir / "c.nvdb", {d, t});
    const std::string file = dir / "c.nvdb";
    EXPECT_EQ(inputError(vdbScene(file, {{"density", "dens"}})),
              "scene.json: volumes[0].source.grids.density: grid 'dens' not found in '" + file +
                  "' (grids: density, temperature)");

    // A density that is not a float grid: the .vdb path's message, OpenVDB's type name.
    openvdb::Int32Grid::Ptr i = openvdb::Int32Grid::create(0);
    i->setName("density");
    i->tree().setValue(Coord(0), 3);
    writeNvdb(dir / "int.nvdb", {i});
    writeVdb(dir / "int.vdb", {i});
    const std::string nvdbError = inputError(vdbScene(dir / "int.nvdb"));
    const std::string vdbError = inputError(vdbScene(dir / "int.vdb"));
    EXPECT_EQ(nvdbError, "scene.json: volumes[0].source.grids.density: grid 'density' in '" + (dir / "int.nvdb") +
                             "' has type int32; a float grid is needed");
    EXPECT_EQ(vdbError.substr(vdbError.find("' has type")), nvdbError.substr(nvdbError.find("' has type")));

    // Not a NanoVDB file, a truncated one, a damaged length, a damaged grid: one line each.
    writeText(dir / "junk.nvdb", "not a nanovdb file, but long enough to hold a header");
    std::string bytes;
    {
        std::ifstream in(file, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    auto writeBytes = [&](const std::string& name, const std::string& b) {
        std::ofstream(dir / name, std::ios::binary).write(b.data(), std::streamsize(b.size()));
        return dir / name;
    };
    // c.nvdb: a 16-byte segment header, the metadata of "density" and "temperature", their grids.
    const size_t meta = sizeof(nanovdb::io::MetaData), nameAt = offsetof(nanovdb::io::MetaData, nameSize);
    std::string nameLength = bytes;
    nameLength[16 + nameAt + 3] = char(0x7f);
    std::string gridSize = bytes;
    gridSize[16 + 7] = char(0x10);  // the first grid's size in memory: 2^60 more
    std::string header = bytes;     // the first grid's own name, inside its partial checksum
    const size_t firstGrid = 16 + meta + 8 + meta + 12;
    ASSERT_EQ(header.substr(firstGrid + offsetof(nanovdb::GridData, mGridName), 7), "density");
    header[firstGrid + offsetof(nanovdb::GridData, mGridName)] = 'D';
    // The grid's index in its buffer past its count: NanoVDB's GridHandle would walk past the
    // buffer looking for grid 0 (fuzz_nvdb's UBSan finding, session 31).
    std::string index = bytes;
    index[firstGrid + offsetof(nanovdb::GridData, mGridIndex)] = char(33);
    struct Case {
        std::string file, expect;
    } cases[] = {
        {dir / "junk.nvdb", "cannot open '" + (dir / "junk.nvdb") + "': not a NanoVDB file"},
        {writeBytes("trunc.nvdb", bytes.substr(0, bytes.size() - 100)), "(truncated or damaged)"},
        {writeBytes("head.nvdb", bytes.substr(0, 40)), "the file ends inside a grid's metadata"},
        {writeBytes("name.nvdb", nameLength), "name where"},
        {writeBytes("size.nvdb", gridSize), "in memory from"},
        {writeBytes("header.nvdb", header), "cannot read grid 'density' from '" + (dir / "header.nvdb") +
                                                "': grid 'density' is damaged (NanoVDB: Mis-matching checksum)"},
        {writeBytes("index.nvdb", index), "grid 'density' says it is grid 33 of 1 in its buffer (damaged)"},
    };
    for (const Case& c : cases) {
        std::string e = inputError(vdbScene(c.file));
        EXPECT_EQ(e.rfind("scene.json: volumes[0].", 0), 0u) << e;
        EXPECT_NE(e.find(c.expect), std::string::npos) << e;
        EXPECT_EQ(e.find('\n'), std::string::npos) << e;
    }
}
