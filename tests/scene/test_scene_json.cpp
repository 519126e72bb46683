// Reading, writing and round-tripping the JSON scene format (docs/scene-format.md).
#include "../TestDir.h"
#include "SceneCompare.h"

#include "core/Error.h"
#include "scene/DefaultScene.h"
#include "scene/SceneJson.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

using namespace nimbus;
using nlohmann::json;

namespace {

const std::string kData = std::string(NIMBUS_TEST_DIR) + "/data/";

Scene parse(const char* text)
{
    return sceneFromJson(json::parse(text), "scene.json");
}

}  // namespace

TEST(SceneJson, EmptyDocumentGivesTheSceneDefaults)
{
    Scene s = parse("{}");
    Scene d;
    test::expectSceneEq(s, d);
    EXPECT_TRUE(s.lights.empty());
    EXPECT_TRUE(s.volumes.empty());
    EXPECT_EQ(s.sourcePath, "scene.json");
}

TEST(SceneJson, FullExampleParses)
{
    Scene s = loadSceneFile(kData + "full.json");
    EXPECT_EQ(s.camera.fov, 35.0f);
    EXPECT_EQ(s.camera.width, 960);
    EXPECT_EQ(s.camera.height, 540);
    EXPECT_EQ(s.camera.crop[0], 0.25f);
    EXPECT_EQ(s.camera.crop[1], 0.75f);
    EXPECT_TRUE(s.camera.hasMotion);
    EXPECT_EQ(s.camera.shutterClose, 0.5f);
    EXPECT_EQ(s.camera.fromClose.x, 0.7f);
    EXPECT_EQ(s.camera.toClose.y, 0.25f) << "motion keys left out keep the shutter-open pose";

    ASSERT_EQ(s.lights.size(), 6u);
    const LightType types[] = {LightType::Distant, LightType::Point,  LightType::Spot,
                               LightType::Rect,    LightType::Sphere, LightType::Environment};
    for (size_t i = 0; i < 6; ++i)
        EXPECT_EQ(s.lights[i].type, types[i]) << i;
    EXPECT_EQ(s.lights[0].name, "sun");
    EXPECT_EQ(s.lights[0].angle, 0.53f);
    EXPECT_EQ(s.lights[1].intensity.y, 20.0f) << "a single number is grey";
    EXPECT_EQ(s.lights[2].coneAngle, 40.0f);
    EXPECT_EQ(s.lights[2].coneSoftness, 8.0f);
    EXPECT_EQ(s.lights[3].size[0], 2.0f);
    EXPECT_EQ(s.lights[3].size[1], 1.0f);
    EXPECT_EQ(s.lights[4].radius, 0.25f);
    EXPECT_EQ(s.lights[5].radiance.z, 0.25f);

    ASSERT_EQ(s.volumes.size(), 2u);
    const Volume& cloud = s.volumes[0];
    EXPECT_EQ(cloud.source.type, SourceType::Procedural);
    EXPECT_EQ(cloud.source.generator, "cloud");
    EXPECT_EQ(cloud.source.params, (std::map<std::string, double>{{"octaves", 5}, {"radius", 2.0}, {"seed", 7}}));
    EXPECT_EQ(cloud.medium.sigma_a.x, 0.025f);
    EXPECT_EQ(cloud.medium.densityScale, 1.5f);
    EXPECT_EQ(cloud.medium.phase.g, 0.8f);
    EXPECT_EQ(cloud.medium.phase.g2, -0.3f);
    EXPECT_EQ(cloud.medium.phase.blend, 0.2f);
    EXPECT_EQ(cloud.medium.emissionScale, 0.0f);
    const Volume& smoke = s.volumes[1];
    EXPECT_EQ(smoke.source.type, SourceType::Vdb);
    EXPECT_EQ(smoke.source.file, kData + "smoke.vdb");
    EXPECT_EQ(smoke.source.grids.at("temperature"), "temp");
    EXPECT_EQ(smoke.transform.at(0, 3), 3.0);
    EXPECT_EQ(smoke.shader, "smoke.ax");

    EXPECT_EQ(s.render.method, Method::Wkb);
    EXPECT_EQ(s.render.seed, 42u);
    EXPECT_EQ(s.render.threads, 2);
    EXPECT_EQ(s.render.spp, 16);
    EXPECT_EQ(s.render.step, 0.25f);
    EXPECT_EQ(s.render.shadowMapResolution, 512);
    EXPECT_EQ(s.render.tolerance, 0.001f);
    EXPECT_EQ(s.render.shadowStep, 0.5f);
    EXPECT_EQ(s.render.lightSamples, 2);
    EXPECT_EQ(s.render.maxDepth, 32);
    EXPECT_EQ(s.render.timeLimit, 60.0);
    EXPECT_EQ(s.output.file, "out/full.exr") << "outputs stay relative to the working directory";
    EXPECT_EQ(s.output.preview, "out/full.png");
    EXPECT_EQ(s.output.aovs, (std::vector<std::string>{"beauty", "L0", "L1", "alpha"}));
    EXPECT_EQ(s.background.z, 0.03f);
}

TEST(SceneJson, EveryExampleSceneParsesAndRoundTrips)
{
    int count = 0;
    for (const auto& entry : std::filesystem::directory_iterator(kData)) {
        std::string name = entry.path().filename().string();
        if (entry.path().extension() != ".json" || name.rfind("invalid_", 0) == 0)
            continue;
        SCOPED_TRACE(name);
        Scene s = loadSceneFile(entry.path().string());
        // Written paths are resolved already; read them back without a file to anchor them.
        Scene back = sceneFromJson(json::parse(sceneToJson(s).dump(2)));
        test::expectSceneEq(back, s);
        ++count;
    }
    EXPECT_GE(count, 4);
}

TEST(SceneJson, OptionalKeysTakeTheirDocumentedDefaults)
{
    Scene s = parse(R"({"lights": [{"type": "point"}, {"type": "distant", "name": "key"}, {"type": "sphere"}],
                        "volumes": [{"source": {"type": "procedural"}}, {"source": {"type": "procedural"}}]})");
    EXPECT_EQ(s.lights[0].name, "0");
    EXPECT_EQ(s.lights[1].name, "key");
    EXPECT_EQ(s.lights[2].name, "2");
    EXPECT_EQ(s.volumes[0].name, "volume0");
    EXPECT_EQ(s.volumes[1].name, "volume1");
    EXPECT_EQ(s.volumes[0].source.generator, "cloud");
    EXPECT_TRUE(s.volumes[0].source.params.empty());
    EXPECT_TRUE(s.volumes[0].shader.empty());
    EXPECT_EQ(s.volumes[0].medium.sigma_s.x, 1.0f);
    EXPECT_EQ(s.volumes[0].medium.phase.g, 0.0f);
    EXPECT_EQ(s.volumes[0].transform.rowMajor(), Transform().rowMajor());
}

TEST(SceneJson, TransformObjectScalesThenRotatesThenTranslates)
{
    Scene s = parse(R"({"volumes": [{"source": {"type": "procedural"},
                        "transform": {"translate": [0, 0, 5], "rotate": [90, 0, 0, 1], "scale": [2, 1, 1]}}]})");
    float3 p = s.volumes[0].transform.point(make_float3(1, 0, 0));
    EXPECT_NEAR(p.x, 0.0f, 1e-6);
    EXPECT_NEAR(p.y, 2.0f, 1e-6);
    EXPECT_NEAR(p.z, 5.0f, 1e-6);
    Scene u = parse(R"({"volumes": [{"source": {"type": "procedural"}, "transform": {"scale": 3}}]})");
    EXPECT_EQ(u.volumes[0].transform.at(1, 1), 3.0);
}

TEST(SceneJson, TransformArrayIsRowMajor)
{
    Scene s = parse(R"({"volumes": [{"source": {"type": "procedural"},
                        "transform": [1, 0, 0, 7, 0, 1, 0, 8, 0, 0, 1, 9, 0, 0, 0, 1]}]})");
    float3 p = s.volumes[0].transform.point(make_float3(0, 0, 0));
    EXPECT_EQ(p.x, 7.0f);
    EXPECT_EQ(p.y, 8.0f);
    EXPECT_EQ(p.z, 9.0f);
}

TEST(SceneJson, VdbFileResolvesAgainstTheSceneDirectoryOnly)
{
    const char* text = R"({"volumes": [{"source": {"type": "vdb", "file": "grids/a.vdb"}},
                                       {"source": {"type": "vdb", "file": "/abs/b.vdb"}}],
                          "output": {"file": "out/a.exr", "preview": "out/a.png"}})";
    Scene s = sceneFromJson(json::parse(text), "/shots/sq010/scene.json");
    EXPECT_EQ(s.volumes[0].source.file, "/shots/sq010/grids/a.vdb");
    EXPECT_EQ(s.volumes[1].source.file, "/abs/b.vdb");
    EXPECT_EQ(s.output.file, "out/a.exr");
    EXPECT_EQ(s.output.preview, "out/a.png");
    Scene local = sceneFromJson(json::parse(text), "scene.json");
    EXPECT_EQ(local.volumes[0].source.file, "grids/a.vdb");
    Scene memory = sceneFromJson(json::parse(text));
    EXPECT_EQ(memory.volumes[0].source.file, "grids/a.vdb");
}

// Issue 17: an environment light's map resolves against the scene file's directory, as VDB
// files do; rotate and intensity are read and written back; a point light's intensity stays RGB.
TEST(SceneJson, EnvironmentMapResolvesAndRoundTrips)
{
    const char* text = R"({"lights": [{"type": "environment", "map": "hdri/sky.exr", "rotate": 45, "intensity": 2.5,
                                        "radiance": [1, 0.9, 0.8]},
                                       {"type": "point", "intensity": [1, 2, 3]}]})";
    Scene s = sceneFromJson(json::parse(text), "/shots/sq010/scene.json");
    ASSERT_EQ(s.lights.size(), 2u);
    EXPECT_EQ(s.lights[0].map, "/shots/sq010/hdri/sky.exr");
    EXPECT_FLOAT_EQ(s.lights[0].rotate, 45.0f);
    EXPECT_FLOAT_EQ(s.lights[0].mapIntensity, 2.5f);
    EXPECT_FLOAT_EQ(s.lights[1].intensity.z, 3.0f);
    const Scene back = sceneFromJson(sceneToJson(s), "/elsewhere/scene.json");  // written absolute: kept
    EXPECT_EQ(back.lights[0].map, s.lights[0].map);
    EXPECT_FLOAT_EQ(back.lights[0].rotate, 45.0f);
    EXPECT_FLOAT_EQ(back.lights[0].mapIntensity, 2.5f);
    EXPECT_THROW(parse(R"({"lights": [{"type": "point", "map": "sky.exr"}]})"), InputError);  // not a point key
}

TEST(SceneJson, VdbGridRolesAndTheHeatAlias)
{
    Scene s = parse(R"({"volumes": [{"source": {"type": "vdb", "file": "a.vdb",
                        "grids": {"density": "dens", "heat": "fire", "Cd": "colour", "vel": "v"}}}]})");
    const auto& g = s.volumes[0].source.grids;
    EXPECT_EQ(g.at("density"), "dens");
    EXPECT_EQ(g.at("flame"), "fire");
    EXPECT_EQ(g.at("Cd"), "colour");
    EXPECT_EQ(g.count("heat"), 0u);
}

TEST(SceneJson, PluginParametersAreKeptAsText)
{
    Scene s = parse(R"({"volumes": [{"source": {"type": "plugin", "path": "libfog.so",
                        "params": {"mode": "dense", "scale": 0.5, "count": 3}}}]})");
    const VolumeSource& src = s.volumes[0].source;
    EXPECT_EQ(src.type, SourceType::Plugin);
    EXPECT_EQ(src.pluginPath, "libfog.so");
    EXPECT_EQ(src.pluginParams.at("mode"), "dense");
    EXPECT_EQ(src.pluginParams.at("scale"), "0.5");
    EXPECT_EQ(src.pluginParams.at("count"), "3");
}

TEST(SceneJson, PhaseSpellings)
{
    Scene s = parse(R"({"volumes": [
        {"source": {"type": "procedural"}, "medium": {"phase": {"type": "hg", "g": 0.7, "g2": -0.2, "blend": 0.3}}},
        {"source": {"type": "procedural"}, "medium": {"phase": {"g": 0.4}}}]})");
    EXPECT_EQ(s.volumes[0].medium.phase.g2, -0.2f);
    EXPECT_EQ(s.volumes[0].medium.phase.blend, 0.3f);
    EXPECT_EQ(s.volumes[1].medium.phase.g, 0.4f);
    EXPECT_EQ(s.volumes[1].medium.phase.blend, 0.0f);
}

TEST(SceneJson, MotionWithoutShutterBlursOverOneFrame)
{
    Scene s = parse(R"({"camera": {"motion": {"to": [1, 0, 0]}}})");
    EXPECT_TRUE(s.camera.hasMotion);
    EXPECT_EQ(s.camera.shutterOpen, 0.0f);
    EXPECT_EQ(s.camera.shutterClose, 1.0f);
    EXPECT_EQ(s.camera.toClose.x, 1.0f);
    EXPECT_EQ(s.camera.fromClose.z, s.camera.from.z);
    Scene still = parse(R"({"camera": {"shutter": [0, 0.5]}})");
    EXPECT_FALSE(still.camera.hasMotion);
    EXPECT_EQ(still.camera.shutterClose, 0.5f);
}

TEST(SceneJson, IntegerValuedFloatsAreIntegers)
{
    Scene s = parse(R"({"render": {"spp": 16.0}, "camera": {"resolution": [320.0, 180]}})");
    EXPECT_EQ(s.render.spp, 16);
    EXPECT_EQ(s.camera.width, 320);
}

// A scene built through the API with a non-default value in every field a format key reaches.
Scene everyFieldScene()
{
    Scene s;
    s.camera.from = make_float3(0.1f, 2.3f, 7.7f);
    s.camera.to = make_float3(-0.3f, 0.2f, 0.1f);
    s.camera.up = make_float3(0.05f, 1, 0);
    s.camera.fov = 27.5f;
    s.camera.width = 1919, s.camera.height = 1081;
    s.camera.crop[0] = 0.1f, s.camera.crop[1] = 0.9f, s.camera.crop[2] = 0.3f, s.camera.crop[3] = 0.7f;
    s.camera.shutterOpen = -0.25f, s.camera.shutterClose = 0.25f;
    s.camera.hasMotion = true;
    s.camera.fromClose = make_float3(0.3f, 2.3f, 7.7f);
    s.camera.toClose = make_float3(-0.2f, 0.2f, 0.1f);
    s.camera.upClose = make_float3(0, 1, 0.01f);
    auto light = [](LightType t, const char* name) {
        Light l;
        l.type = t, l.name = name;
        return l;
    };
    Light d = light(LightType::Distant, "d");
    d.direction = make_float3(0.3f, -0.9f, 0.1f), d.irradiance = make_float3(1.1f, 2.2f, 3.3f), d.angle = 0.53f;
    Light p = light(LightType::Point, "p");
    p.position = make_float3(1, 2, 3), p.intensity = make_float3(0.1f, 0.2f, 0.3f);
    Light sp = light(LightType::Spot, "sp");
    sp.position = make_float3(-1, 4, 2), sp.direction = make_float3(0.2f, -1, -0.4f);
    sp.intensity = splat(7.0f), sp.coneAngle = 33.3f, sp.coneSoftness = 3.3f;
    Light r = light(LightType::Rect, "r");
    r.center = make_float3(0, 3, 1), r.normal = make_float3(0, -1, 0.1f), r.up = make_float3(1, 0, 0);
    r.size[0] = 0.7f, r.size[1] = 1.3f, r.radiance = make_float3(5, 6, 7);
    Light sph = light(LightType::Sphere, "sph");
    sph.position = make_float3(2, 2, -2), sph.radius = 0.123f, sph.radiance = splat(12.5f);
    Light env = light(LightType::Environment, "env");
    env.radiance = make_float3(0.01f, 0.02f, 0.04f);
    s.lights = {d, p, sp, r, sph, env};

    Volume a;
    a.name = "a";
    a.source.type = SourceType::Vdb;
    a.source.file = "/data/a.vdb";
    a.source.grids = {{"density", "rho"}, {"temperature", "T"}, {"flame", "heat"}};
    a.transform = Transform::translate(0.1, 0.2, 0.3) * Transform::rotateDegrees(17, 0.3, 1, 0.2) *
                  Transform::scale(0.01, 0.02, 0.03);
    a.medium.sigma_s = make_float3(1.5f, 1.6f, 1.7f);
    a.medium.sigma_a = make_float3(0.01f, 0.02f, 0.03f);
    a.medium.densityScale = 0.75f;
    a.medium.phase = {0.85f, -0.35f, 0.15f, 0.0f};
    a.medium.emissionScale = 2.5f;
    a.shader = "shaders/fire.ax";
    Volume b;
    b.name = "b";
    b.source.generator = "sphere";
    b.source.params = {{"radius", 1.25}, {"falloff", 0.1}};
    b.medium.phase = {-0.2f, 0.0f, 0.0f, 0.0f};
    Volume c;
    c.name = "c";
    c.source.type = SourceType::Plugin;
    c.source.pluginPath = "plugins/libnoise.so";
    c.source.pluginParams = {{"octaves", "4"}, {"mode", "turbulent"}};
    s.volumes = {a, b, c};

    s.render.method = Method::Pathtrace;
    s.render.seed = 4000000000u;
    s.render.threads = 3, s.render.spp = 77, s.render.step = 0.33f, s.render.shadowMapResolution = 1000;
    s.render.tolerance = 0.0005f, s.render.shadowStep = 0.75f, s.render.lightSamples = 5;
    s.render.maxDepth = 9, s.render.timeLimit = 12.5, s.render.noiseTarget = 3e-5;
    s.render.equiangular = false;
    s.output.file = "renders/x.exr", s.output.preview = "renders/x.png", s.output.aovs = {"beauty", "depth"};
    s.background = make_float3(0.001f, 0.002f, 0.003f);
    return s;
}

TEST(SceneJson, RoundTripKeepsEveryField)
{
    Scene s = everyFieldScene();
    test::expectSceneEq(sceneFromJson(sceneToJson(s)), s);
    // Through text as well: the written numbers are short decimals that read back exactly.
    test::expectSceneEq(sceneFromJson(json::parse(sceneToJson(s).dump())), s);
}

TEST(SceneJson, WrittenNumbersAreShortDecimals)
{
    Scene s;
    s.render.tolerance = 0.1f;
    EXPECT_EQ(sceneToJson(s)["render"]["tolerance"].dump(), "0.1");
}

TEST(SceneJson, WrittenSceneNamesTheFormatVersion)
{
    EXPECT_EQ(sceneToJson(Scene())["version"], kSceneFormatVersion);
}

TEST(SceneJson, ReadJsonFileMissingFile)
{
    std::string path = kData + "no_such_scene.json";
    try {
        readJsonFile(path);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()), path + ": cannot open scene file: No such file or directory");
    }
}

TEST(SceneJson, ReadJsonFileReportsLineAndColumn)
{
    std::string path = kData + "invalid_syntax.json";
    try {
        loadSceneFile(path);
        FAIL() << "no error";
    } catch (const InputError& e) {
        std::string m = e.what();
        EXPECT_EQ(m.rfind(path + ": invalid JSON at line 4, column ", 0), 0u) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
        EXPECT_EQ(m.find("json.exception"), std::string::npos) << m;
    }
}

TEST(SceneJson, ReadJsonFileNumberOverflow)
{
    std::string path = (std::filesystem::temp_directory_path() / "nimbus_overflow.json").string();
    std::ofstream(path) << "{\n  \"render\": {\"spp\": 1e999}\n}\n";
    try {
        readJsonFile(path);
        FAIL() << "no error";
    } catch (const InputError& e) {
        std::string m = e.what();
        EXPECT_EQ(m.rfind(path + ": invalid JSON at line 2, column 21: ", 0), 0u) << m;
    }
    std::filesystem::remove(path);
}

// Geometry and the depth-map holdout (issue 14): every key survives the round trip, relative
// files resolve against the scene's directory as VDB files do, a key of another type is an error.
TEST(SceneJson, GeometryRoundTripsAndResolvesFiles)
{
    const json doc = json::parse(R"({
      "camera": {"holdout_depth": {"file": "z.exr", "channel": "depth"}},
      "geometry": [
        {"name": "wall", "type": "mesh", "file": "wall.obj", "transform": {"translate": [1, 2, 3]}, "shadows": false},
        {"type": "sphere", "radius": 0.5, "holdout": false},
        {"type": "plane", "size": [20, 10]},
        {"type": "plane"}
      ]})");
    const Scene s = sceneFromJson(doc, "/shots/a/scene.json");
    ASSERT_EQ(s.geometry.size(), 4u);
    EXPECT_EQ(s.geometry[0].file, "/shots/a/wall.obj");
    EXPECT_EQ(s.geometry[0].transform.at(1, 3), 2.0);
    EXPECT_FALSE(s.geometry[0].shadows);
    EXPECT_TRUE(s.geometry[0].holdout);
    EXPECT_EQ(s.geometry[1].name, "geometry1");
    EXPECT_EQ(s.geometry[1].radius, 0.5f);
    EXPECT_FALSE(s.geometry[1].holdout);
    EXPECT_TRUE(s.geometry[2].bounded);
    EXPECT_EQ(s.geometry[2].size[1], 10.0f);
    EXPECT_FALSE(s.geometry[3].bounded);  // size omitted: infinite
    EXPECT_EQ(s.camera.holdoutDepth.file, "/shots/a/z.exr");
    EXPECT_EQ(s.camera.holdoutDepth.channel, "depth");
    const Scene back = sceneFromJson(json::parse(sceneToJson(s).dump()), "");
    ASSERT_EQ(back.geometry.size(), 4u);
    for (size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(back.geometry[i].name, s.geometry[i].name);
        EXPECT_EQ(back.geometry[i].type, s.geometry[i].type);
        EXPECT_EQ(back.geometry[i].file, s.geometry[i].file);
        EXPECT_EQ(back.geometry[i].radius, s.geometry[i].radius);
        EXPECT_EQ(back.geometry[i].bounded, s.geometry[i].bounded);
        EXPECT_EQ(back.geometry[i].size[0], s.geometry[i].size[0]);
        EXPECT_EQ(back.geometry[i].transform.rowMajor(), s.geometry[i].transform.rowMajor());
        EXPECT_EQ(back.geometry[i].holdout, s.geometry[i].holdout);
        EXPECT_EQ(back.geometry[i].shadows, s.geometry[i].shadows);
    }
    EXPECT_EQ(back.camera.holdoutDepth.file, s.camera.holdoutDepth.file);
    EXPECT_EQ(back.camera.holdoutDepth.channel, s.camera.holdoutDepth.channel);
    // A scene without geometry writes no "geometry" key (its JSON is as before).
    EXPECT_FALSE(sceneToJson(Scene()).contains("geometry"));
    EXPECT_FALSE(sceneToJson(Scene())["camera"].contains("holdout_depth"));
}

TEST(SceneJson, GeometryKeyErrors)
{
    auto error = [](const char* text) {
        try {
            sceneFromJson(json::parse(text), "s.json");
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_NE(error(R"({"geometry": [{"type": "mesh", "file": "m.obj", "radius": 1}]})").find("geometry[0]"),
              std::string::npos);
    EXPECT_NE(error(R"({"geometry": [{"type": "cube"}]})").find("unknown geometry type 'cube'"), std::string::npos);
    EXPECT_NE(error(R"({"geometry": [{"type": "mesh"}]})").find("geometry[0].file"), std::string::npos);
    EXPECT_NE(error(R"({"geometry": [{"type": "sphere", "radius": -1}]})").find("geometry[0].radius"),
              std::string::npos);
    EXPECT_NE(error(R"({"geometry": [{"type": "plane", "size": [0, 1]}]})").find("geometry[0].size[0]"),
              std::string::npos);
    EXPECT_NE(error(R"({"geometry": [{"type": "sphere", "holdout": 1}]})").find("geometry[0].holdout"),
              std::string::npos);
    EXPECT_NE(error(R"({"geometry": [{"type": "sphere", "transform": {"scale": 0}}]})").find("geometry[0].transform"),
              std::string::npos);
    EXPECT_NE(error(R"({"camera": {"holdout_depth": {"channel": "Z"}}})").find("camera.holdout_depth.file"),
              std::string::npos);
    EXPECT_NE(error(R"({"camera": {"holdout_depth": {"file": "z.exr", "scale": 2}}})").find("camera.holdout_depth"),
              std::string::npos);
    // The path tracer renders geometry and depth maps too (issue 14, item 3): no error.
    EXPECT_EQ(error(R"({"geometry": [{"type": "sphere"}], "render": {"method": "pathtrace", "spp": 4}})"), "");
}
