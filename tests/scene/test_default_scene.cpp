// The embedded default scene: valid, what the brief promises, and equal to its documented JSON.
#include "../TestDir.h"
#include "SceneCompare.h"

#include "scene/DefaultScene.h"
#include "scene/SceneJson.h"
#include "scene/SceneValidate.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

using namespace nimbus;

TEST(DefaultScene, IsValidAndAsDocumented)
{
    Scene s = defaultScene();
    EXPECT_NO_THROW(validateScene(s));
    EXPECT_EQ(s.camera.width, 640);
    EXPECT_EQ(s.camera.height, 360);
    EXPECT_EQ(s.render.method, Method::Wkb) << "multiple scattering, the picture a newcomer should see";
    EXPECT_EQ(s.output.file, "out/default.exr");
    EXPECT_EQ(s.output.preview, "out/default.png");
    ASSERT_EQ(s.volumes.size(), 1u);
    EXPECT_EQ(s.volumes[0].source.type, SourceType::Procedural);
    EXPECT_EQ(s.volumes[0].source.generator, "cloud");
    ASSERT_EQ(s.lights.size(), 2u);
    const Light &key = s.lights[0], &sky = s.lights[1];
    EXPECT_EQ(key.type, LightType::Distant) << "a sun";
    EXPECT_NEAR(nbAverage(key.irradiance), 3.0f, 0.2f);
    EXPECT_GT(key.irradiance.x, key.irradiance.z) << "warm";
    EXPECT_EQ(sky.type, LightType::Environment) << "and a sky";
    EXPECT_TRUE(sky.map.empty());
    EXPECT_LT(sky.radiance.x, sky.radiance.z) << "blue";
    // A clear sky gives a level surface a fifth to a tenth of the sun's irradiance.
    const float skyIrradiance = NB_PI * nbAverage(sky.radiance);
    EXPECT_GT(skyIrradiance, 0.1f * nbAverage(key.irradiance));
    EXPECT_LT(skyIrradiance, 0.2f * nbAverage(key.irradiance));
    EXPECT_GT(key.direction.x, 0.0f) << "travels away from the left";
    EXPECT_LT(key.direction.y, 0.0f) << "comes from above";
    EXPECT_LT(key.direction.z, 0.0f) << "comes from the front (the camera's side)";
}

TEST(DefaultScene, FramesACloudOfTwoMetresAtTheOrigin)
{
    const Camera& c = defaultScene().camera;
    float distance = length(c.to - c.from);
    float halfHeight = distance * std::tan(0.5f * c.fov * NB_PI / 180.0f);
    EXPECT_GT(halfHeight, 2.0f) << "the whole cloud fits vertically";
    EXPECT_LT(halfHeight, 4.5f) << "and fills a good part of the frame";
    EXPECT_LT(length(c.to), 0.5f);
}

TEST(DefaultScene, EqualsItsJsonForm)
{
    Scene fromFile = loadSceneFile(std::string(NIMBUS_TEST_DIR) + "/data/default.json");
    test::expectSceneEq(fromFile, defaultScene());
    test::expectSceneEq(sceneFromJson(sceneToJson(defaultScene())), defaultScene());
}
