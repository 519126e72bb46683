// test_capi_cpp.cpp: the C++ RAII wrapper (nimbus.hpp): references are counted through copies
// and moves, failures become exceptions with the C status, callbacks cancel.
#include "nimbus.hpp"

#include <gtest/gtest.h>

#include <cstring>

using namespace nimbus::embed;

namespace {

Scene smallScene()
{
    Scene scene = Scene::create();
    Camera camera = scene.camera();
    camera.set("resolution", std::vector<double>{32, 24}).set("from", 0, 0, 4);
    Light sun = Light::create("distant");
    sun.set("irradiance", 2.0).set("name", "sun");
    scene.add(sun);
    Volume ball = Volume::create("procedural");
    ball.set("source.generator", "sphere").set("source.voxel_size", 0.05).set("medium.sigma_s", 2.0);
    scene.add(ball);
    scene.set("render.spp", 1);
    scene.commit();
    return scene;
}

}  // namespace

TEST(CapiCpp, RendersAndKeepsFramesAlive)
{
    Scene scene = smallScene();
    Frame frame = Session(scene).render();  // the session is gone, the frame stays
    Frame copy = frame;
    NimbusAov beauty = copy.aov("beauty");
    EXPECT_EQ(beauty.width, 32);
    EXPECT_EQ(beauty.channels, 4);
    EXPECT_GT(beauty.pixels[(12 * 32 + 16) * 4 + 3], 0.5f);
    EXPECT_EQ(frame.aovs().size(), 6u);
    EXPECT_EQ(scene.lights().size(), 1u);
    EXPECT_EQ(scene.volumes().size(), 1u);
    EXPECT_NE(scene.toJson().find("\"sphere\""), std::string::npos);
}

TEST(CapiCpp, ErrorsAreExceptionsWithStatus)
{
    Scene scene = smallScene();
    try {
        scene.set("render.sp", 4);
        FAIL() << "no exception";
    } catch (const Exception& e) {
        EXPECT_EQ(e.status(), NIMBUS_ERROR_UNKNOWN_PARAMETER);
        EXPECT_NE(std::strstr(e.what(), "did you mean 'spp'"), nullptr);
    }
    EXPECT_THROW(scene.camera().set("fov", "wide"), Exception);
    EXPECT_THROW(Light::create("laser"), Exception);
}

TEST(CapiCpp, ProgressCallbackCancels)
{
    Scene scene = smallScene();
    Session session(scene);
    int calls = 0;
    session.onProgress([&](float) {
        ++calls;
        return false;
    });
    try {
        session.render();
        FAIL() << "not cancelled";
    } catch (const Exception& e) {
        EXPECT_EQ(e.status(), NIMBUS_ERROR_CANCELLED);
    }
    EXPECT_GE(calls, 1);
    session.onProgress(nullptr);
    session.start();
    EXPECT_TRUE(session.wait());
    EXPECT_GE(session.frame().seconds(), 0.0);
}
