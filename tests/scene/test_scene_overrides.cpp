// The CLI's --set key.path=value, applied before parsing.
#include "../TestDir.h"
#include "core/Error.h"
#include "scene/SceneJson.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

using namespace nimbus;
using nlohmann::json;

namespace {

const std::string kFull = std::string(NIMBUS_TEST_DIR) + "/data/full.json";

std::string overrideError(const std::vector<std::string>& sets)
{
    try {
        loadSceneFile(kFull, sets);
    } catch (const InputError& e) {
        std::string m = e.what();
        EXPECT_EQ(m.rfind(kFull + ": ", 0), 0u) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
        return m;
    }
    ADD_FAILURE() << "no InputError";
    return "";
}

}  // namespace

TEST(SceneOverrides, SetsNumbersArraysStringsAndNestedKeys)
{
    Scene s = loadSceneFile(kFull, {"render.spp=3", "camera.resolution=[320,180]", "lights[0].irradiance=[1,1,1]",
                                    "volumes[0].medium.phase.g=0.5", "render.method=single",
                                    "output.file=out/override test.exr", "lights[1].intensity=2"});
    EXPECT_EQ(s.render.spp, 3);
    EXPECT_EQ(s.camera.width, 320);
    EXPECT_EQ(s.camera.height, 180);
    EXPECT_EQ(s.lights[0].irradiance.y, 1.0f);
    EXPECT_EQ(s.volumes[0].medium.phase.g, 0.5f);
    EXPECT_EQ(s.render.method, Method::Single);
    EXPECT_EQ(s.output.file, "out/override test.exr");
    EXPECT_EQ(s.lights[1].intensity.z, 2.0f);
}

TEST(SceneOverrides, LaterOverridesWin)
{
    Scene s = loadSceneFile(kFull, {"render.spp=3", "render.spp=5"});
    EXPECT_EQ(s.render.spp, 5);
}

TEST(SceneOverrides, CreatesMissingObjects)
{
    json doc = json::object();
    applyOverrides(doc, {"render.spp=16", "camera.motion.to=[0,0,1]"}, "");
    Scene s = sceneFromJson(doc);
    EXPECT_EQ(s.render.spp, 16);
    EXPECT_TRUE(s.camera.hasMotion);
}

TEST(SceneOverrides, OverriddenValuesAreValidatedLikeTheFile)
{
    EXPECT_NE(overrideError({"render.spp=-2"}).find("render.spp: must be at least 0"), std::string::npos);
    EXPECT_NE(overrideError({"render.spp=many"}).find("render.spp: expected an integer, got string"),
              std::string::npos);
    EXPECT_NE(overrideError({"render.bogus=1"}).find("render.bogus: unknown key"), std::string::npos);
    EXPECT_NE(overrideError({"volumes[0].medium.phase.g=1.5"}).find("volumes[0].medium.phase.g: must be in"),
              std::string::npos);
}

TEST(SceneOverrides, MalformedOverridesNameThemselves)
{
    EXPECT_NE(overrideError({"render.spp"}).find("--set 'render.spp': expected key.path=value"), std::string::npos);
    EXPECT_NE(overrideError({"=3"}).find("--set '=3': the key path before '=' is empty"), std::string::npos);
    EXPECT_NE(overrideError({"render..spp=3"}).find("--set 'render..spp=3': expected a key name"), std::string::npos);
    EXPECT_NE(overrideError({"render.spp.=3"}).find("--set 'render.spp.=3'"), std::string::npos);
    EXPECT_NE(overrideError({"lights[x].name=a"}).find("--set 'lights[x].name=a': expected a list index"),
              std::string::npos);
    EXPECT_NE(overrideError({"lights[0.name=a"}).find("expected a list index"), std::string::npos);
    EXPECT_NE(overrideError({"lights[9].name=a"}).find("--set 'lights[9].name=a': 'lights' has 6 entries, no [9]"),
              std::string::npos);
    EXPECT_NE(overrideError({"render[0]=1"}).find("'render' is an object, not a list"), std::string::npos);
    EXPECT_NE(overrideError({"render.spp.x=1"}).find("'render.spp' is a number, not an object"), std::string::npos);
    EXPECT_NE(overrideError({"cameras[0].fov=1"}).find("'cameras' is missing, not a list"), std::string::npos);
}

TEST(SceneOverrides, PlusAppendsToAList)
{
    const size_t before = loadSceneFile(kFull).lights.size();
    Scene s =
        loadSceneFile(kFull, {R"(lights[+]={"name": "extra", "type": "point", "position": [0, 2, 0], "intensity": 5})",
                              "lights[+].type=distant", "lights[+]={\"type\": \"distant\"}"});
    ASSERT_EQ(s.lights.size(), before + 3);
    EXPECT_EQ(s.lights[before].name, "extra");
    EXPECT_EQ(s.lights[before].type, LightType::Point);
    EXPECT_EQ(s.lights[before].intensity.x, 5.0f);
    EXPECT_EQ(s.lights[before + 1].type, LightType::Distant);
    EXPECT_EQ(s.lights[before + 2].type, LightType::Distant);
    // The appended entry is checked like one in the file, and named by its index.
    EXPECT_NE(overrideError({"lights[+]={\"type\": \"point\", \"intensity\": -1}"})
                  .find("lights[" + std::to_string(before) + "].intensity"),
              std::string::npos);
    // A missing list is created; something else is not a list.
    json doc = json::object();
    applyOverrides(doc, {R"(lights[+]={"type": "distant"})"}, "");
    ASSERT_TRUE(doc["lights"].is_array());
    EXPECT_EQ(doc["lights"].size(), 1u);
    EXPECT_NE(overrideError({"render[+]=1"}).find("'render' is an object, not a list"), std::string::npos);
}
