// validateScene on scenes built through the API, where values JSON cannot hold (NaN, inf) and
// empty names can appear.
#include "core/Error.h"
#include "scene/DefaultScene.h"
#include "scene/SceneValidate.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nimbus;

namespace {

std::string errorOf(const Scene& s)
{
    try {
        validateScene(s);
    } catch (const InputError& e) {
        return e.what();
    }
    ADD_FAILURE() << "no InputError";
    return "";
}

Scene oneVolume()
{
    Scene s;
    s.volumes.emplace_back();
    s.volumes[0].name = "v";
    return s;
}

}  // namespace

TEST(SceneValidate, DefaultsAreValid)
{
    EXPECT_NO_THROW(validateScene(Scene()));
    EXPECT_NO_THROW(validateScene(oneVolume()));
    EXPECT_NO_THROW(validateScene(defaultScene()));
}

TEST(SceneValidate, MessageNamesSourcePathWhenThereIsOne)
{
    Scene s;
    s.camera.fov = 0;
    EXPECT_EQ(errorOf(s), "camera.fov: must be in (0, 180) degrees, got 0");
    s.sourcePath = "shot.json";
    EXPECT_EQ(errorOf(s), "shot.json: camera.fov: must be in (0, 180) degrees, got 0");
}

TEST(SceneValidate, NanAndInfinityAnywhere)
{
    const float nan = NAN, inf = INFINITY;
    Scene s = oneVolume();
    s.volumes[0].medium.sigma_s.y = nan;
    EXPECT_EQ(errorOf(s), "volumes[0].medium.sigma_s: must be non-negative and finite, got [1, nan, 1]");
    s = oneVolume();
    s.volumes[0].medium.phase.g = nan;
    EXPECT_NE(errorOf(s).find("volumes[0].medium.phase.g: must be in"), std::string::npos);
    s = Scene();
    s.camera.fov = nan;
    EXPECT_NE(errorOf(s).find("camera.fov: must be in (0, 180) degrees, got nan"), std::string::npos);
    s = Scene();
    s.camera.from.x = inf;
    EXPECT_NE(errorOf(s).find("camera.from: must be finite"), std::string::npos);
    s = Scene();
    s.render.timeLimit = INFINITY;
    EXPECT_NE(errorOf(s).find("render.time_limit"), std::string::npos);
    s = Scene();
    s.camera.crop[1] = nan;
    EXPECT_NE(errorOf(s).find("camera.crop"), std::string::npos);
    s = Scene();
    s.camera.shutterClose = nan;
    EXPECT_NE(errorOf(s).find("camera.shutter"), std::string::npos);
    s = oneVolume();
    s.volumes[0].source.params["radius"] = nan;
    EXPECT_NE(errorOf(s).find("volumes[0].source.radius: must be finite"), std::string::npos);
    s = oneVolume();
    s.volumes[0].transform = Transform::translate(inf, 0, 0);
    EXPECT_NE(errorOf(s).find("volumes[0].transform: must be finite"), std::string::npos);
    s = Scene();
    Light l;
    l.name = "p";
    l.type = LightType::Point;
    l.position.z = nan;
    s.lights.push_back(l);
    EXPECT_NE(errorOf(s).find("lights[0].position: must be finite"), std::string::npos);
}

TEST(SceneValidate, EmptyNamesAndTheirDefaults)
{
    Scene s = oneVolume();
    s.volumes[0].name.clear();
    s.lights.resize(2);
    EXPECT_NE(errorOf(s).find("lights[0].name: must match"), std::string::npos);
    applyDefaultNames(s);
    EXPECT_EQ(s.lights[0].name, "0");
    EXPECT_EQ(s.lights[1].name, "1");
    EXPECT_EQ(s.volumes[0].name, "volume0");
    EXPECT_NO_THROW(validateScene(s));
}

TEST(SceneValidate, SourcesNeedTheirData)
{
    Scene s = oneVolume();
    s.volumes[0].source.type = SourceType::Plugin;
    EXPECT_NE(errorOf(s).find("volumes[0].source.path: a plugin source needs"), std::string::npos);
    s.volumes[0].source.type = SourceType::Vdb;
    EXPECT_NE(errorOf(s).find("volumes[0].source.file: a vdb source needs a file"), std::string::npos);
    s.volumes[0].source.file = "a.vdb";
    s.volumes[0].source.grids["density"] = "";
    EXPECT_NE(errorOf(s).find("volumes[0].source.grids.density: grid name must not be empty"), std::string::npos);
}

// Issue 17: one environment map per scene (the path tracer samples one); rotate finite,
// intensity >= 0.
TEST(SceneValidate, EnvironmentMapKeys)
{
    Scene s;
    Light sky;
    sky.type = LightType::Environment;
    sky.name = "a";
    sky.map = "a.exr";
    s.lights.push_back(sky);
    EXPECT_NO_THROW(validateScene(s));
    sky.name = "b";
    sky.map = "b.exr";
    s.lights.push_back(sky);
    EXPECT_NE(errorOf(s).find("lights[1].map"), std::string::npos) << errorOf(s);
    s.lights.pop_back();
    s.lights[0].rotate = INFINITY;
    EXPECT_NE(errorOf(s).find("lights[0].rotate"), std::string::npos) << errorOf(s);
    s.lights[0].rotate = 0.0f;
    s.lights[0].mapIntensity = -1.0f;
    EXPECT_NE(errorOf(s).find("lights[0].intensity"), std::string::npos) << errorOf(s);
}
