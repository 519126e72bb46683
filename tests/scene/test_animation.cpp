// Animation keys (Animation.h, docs/scene-format.md "Animation"; issue 16, item 2): linear and
// slerp interpolation against closed forms, the T R S split, the JSON contract and its errors,
// and a frame's scene (keys evaluated at the frame and across the shutter).
#include "core/Error.h"
#include "scene/Animation.h"
#include "scene/FrameTokens.h"
#include "scene/SceneJson.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>

namespace nimbus {
namespace {

using nlohmann::json;

void expectNear(float3 a, float3 b, float tol)
{
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

void expectNear(const Transform& a, const Transform& b, double tol)
{
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            EXPECT_NEAR(a.at(r, c), b.at(r, c), tol) << "row " << r << " col " << c;
}

TEST(Animation, VectorsInterpolateLinearlyAndHoldOutsideTheKeys)
{
    Keys<float3> k;
    k.frames = {1.0, 3.0, 4.0};
    k.values = {make_float3(0, 0, 0), make_float3(2, 4, 6), make_float3(2, 4, 10)};
    expectNear(evaluateKeys(k, 2.0), make_float3(1, 2, 3), 0.0f);
    expectNear(evaluateKeys(k, 1.5), make_float3(0.5f, 1, 1.5f), 1e-6f);
    expectNear(evaluateKeys(k, 3.5), make_float3(2, 4, 8), 0.0f);
    expectNear(evaluateKeys(k, 3.0), make_float3(2, 4, 6), 0.0f);  // on a key: that key
    expectNear(evaluateKeys(k, -100.0), make_float3(0, 0, 0), 0.0f);
    expectNear(evaluateKeys(k, 1e9), make_float3(2, 4, 10), 0.0f);
    Keys<float> fov;
    fov.frames = {10.0, 20.0};
    fov.values = {40.0f, 20.0f};
    EXPECT_FLOAT_EQ(evaluateKeys(fov, 15.0), 30.0f);
    EXPECT_FLOAT_EQ(evaluateKeys(fov, 12.5), 35.0f);
    Keys<float> one;
    one.frames = {5.0};
    one.values = {7.0f};
    EXPECT_EQ(evaluateKeys(one, 0.0), 7.0f);
    EXPECT_EQ(evaluateKeys(one, 9.0), 7.0f);
}

TEST(Animation, RotationsSlerpAlongTheShorterArc)
{
    Keys<Transform> k;
    k.frames = {0.0, 1.0};
    k.values = {Transform::rotateDegrees(0, 0, 1, 0), Transform::rotateDegrees(90, 0, 1, 0)};
    for (double u : {0.25, 0.5, 0.9})
        expectNear(evaluateKeys(k, u), Transform::rotateDegrees(90 * u, 0, 1, 0), 1e-12);
    // 10 and 350 degrees: the shorter arc passes 0, not 180.
    k.values = {Transform::rotateDegrees(10, 1, 1, 0), Transform::rotateDegrees(350, 1, 1, 0)};
    expectNear(evaluateKeys(k, 0.5), Transform(), 1e-12);
    expectNear(evaluateKeys(k, 0.25), Transform::rotateDegrees(5, 1, 1, 0), 1e-12);
}

TEST(Animation, TranslationAndScaleInterpolateLinearlyBesideTheRotation)
{
    const Transform a = Transform::translate(1, 2, 3) * Transform::rotateDegrees(20, 0, 0, 1) * Transform::scale(1, 2, 4);
    const Transform b =
        Transform::translate(5, -2, 3) * Transform::rotateDegrees(80, 0, 0, 1) * Transform::scale(3, 2, 0.5);
    Keys<Transform> k;
    k.frames = {2.0, 6.0};
    k.values = {a, b};
    const Transform mid = Transform::translate(3, 0, 3) * Transform::rotateDegrees(50, 0, 0, 1) * Transform::scale(2, 2, 2.25);
    expectNear(evaluateKeys(k, 4.0), mid, 1e-12);
    expectNear(evaluateKeys(k, 2.0), a, 0.0);
    expectNear(evaluateKeys(k, 6.0), b, 0.0);
}

TEST(Animation, TrsSplitRoundTripsMirrorsAndRefusesShear)
{
    const Transform t = Transform::translate(-4, 0.5, 9) * Transform::rotateDegrees(123, 0.3, -1, 0.2) *
                        Transform::scale(-2, 0.25, 3);  // a mirror
    expectNear(composeTrs(splitTrs(t)), t, 1e-12);
    std::array<double, 16> shear = {1, 0.5, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    EXPECT_THROW(splitTrs(Transform::fromRowMajor(shear)), std::invalid_argument);
    EXPECT_THROW(splitTrs(Transform::scale(1, 0, 1)), std::invalid_argument);
}

json baseScene()
{
    return json::parse(R"({
      "camera": {"from": [0, 0, 5], "to": [0, 0, 0], "fov": 40, "resolution": [8, 8]},
      "lights": [{"type": "point", "position": [0, 4, 0], "intensity": 10}],
      "volumes": [{"source": {"type": "procedural", "generator": "sphere", "radius": 1, "voxel_size": 0.1}}]
    })");
}

TEST(Animation, KeyListsParseSortedAndRoundTrip)
{
    json doc = baseScene();
    doc["camera"]["from"] = json::parse(R"([{"frame": 10, "value": [0, 0, 9]}, {"frame": 1, "value": [0, 0, 5]}])");
    doc["camera"]["fov"] = json::parse(R"([{"frame": 1, "value": 40}, {"frame": 10, "value": 20}])");
    doc["lights"][0]["position"] = json::parse(R"([{"frame": 1, "value": [0, 4, 0]}, {"frame": 5, "value": [4, 4, 0]}])");
    doc["volumes"][0]["transform"] = json::parse(
        R"([{"frame": 1, "value": {"translate": [0, 0, 0]}}, {"frame": 5, "value": {"rotate": [90, 0, 1, 0], "translate": [1, 0, 0]}}])");
    const Scene s = sceneFromJson(doc);
    ASSERT_EQ(s.camera.fromKeys.frames, (std::vector<double>{1.0, 10.0}));
    expectNear(s.camera.from, make_float3(0, 0, 5), 0.0f);  // the first key's value until evaluated
    expectNear(s.camera.fromKeys.values[1], make_float3(0, 0, 9), 0.0f);
    EXPECT_EQ(s.camera.fovKeys.values.size(), 2u);
    EXPECT_EQ(s.lights[0].positionKeys.frames.size(), 2u);
    EXPECT_EQ(s.volumes[0].transformKeys.frames.size(), 2u);
    // Written back as key lists, read back the same.
    const Scene again = sceneFromJson(sceneToJson(s));
    EXPECT_EQ(again.camera.fromKeys.frames, s.camera.fromKeys.frames);
    expectNear(again.camera.fromKeys.values[1], s.camera.fromKeys.values[1], 0.0f);
    EXPECT_EQ(again.camera.fovKeys.values, s.camera.fovKeys.values);
    EXPECT_EQ(again.volumes[0].transformKeys.values[1].rowMajor(), s.volumes[0].transformKeys.values[1].rowMajor());
    EXPECT_EQ(sceneToJson(again), sceneToJson(s));
}

void expectError(const json& doc, const std::string& fragment)
{
    try {
        (void)sceneFromJson(doc, "shot.json");
        ADD_FAILURE() << "accepted; expected an error with '" << fragment << "'";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("shot.json"), std::string::npos) << e.what();
    }
}

TEST(Animation, BadKeysAreInputErrorsNamingTheKey)
{
    json doc = baseScene();
    doc["camera"]["from"] = json::parse(R"([{"frame": 1, "value": [0, 0, 5]}, 7])");
    expectError(doc, "camera.from[1]");
    doc["camera"]["from"] = json::parse(R"([{"frame": 1}])");
    expectError(doc, "camera.from[0].value");
    doc["camera"]["from"] = json::parse(R"([{"value": [0, 0, 5]}])");
    expectError(doc, "camera.from[0].frame");
    doc["camera"]["from"] = json::parse(R"([{"frame": 1, "value": [0, 0, 5], "ease": "in"}])");
    expectError(doc, "ease");
    doc["camera"]["from"] = json::parse(R"([{"frame": 2, "value": [0, 0, 5]}, {"frame": 2, "value": [0, 0, 6]}])");
    expectError(doc, "camera.from[1]");
    doc["camera"]["from"] = json::parse(R"([{"frame": 1, "value": [0, 0]}])");
    expectError(doc, "camera.from[0].value");
    doc = baseScene();
    doc["volumes"][0]["transform"] =
        json::parse(R"([{"frame": 1, "value": [1, 0.5, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}])");
    expectError(doc, "volumes[0].transform[0].value");
    doc = baseScene();
    doc["camera"]["from"] = json::parse(R"([{"frame": 1, "value": [0, 0, 5]}, {"frame": 2, "value": [0, 0, 6]}])");
    doc["camera"]["motion"] = json::parse(R"({"from": [0, 0, 7]})");
    expectError(doc, "camera.motion");
}

TEST(Animation, AFramesSceneHoldsTheKeysValuesAndTheShutterBlursTheCamera)
{
    json doc = baseScene();
    doc["camera"]["from"] = json::parse(R"([{"frame": 1, "value": [0, 0, 5]}, {"frame": 5, "value": [4, 0, 5]}])");
    doc["camera"]["fov"] = json::parse(R"([{"frame": 1, "value": 40}, {"frame": 5, "value": 20}])");
    doc["lights"][0]["position"] = json::parse(R"([{"frame": 1, "value": [0, 4, 0]}, {"frame": 5, "value": [8, 4, 0]}])");
    doc["volumes"][0]["transform"] =
        json::parse(R"([{"frame": 1, "value": {"translate": [0, 0, 0]}}, {"frame": 5, "value": {"translate": [0, 2, 0]}}])");
    const Scene templ = sceneFromJson(doc);

    // No shutter: everything at the frame, no motion blur, no keys left.
    const Scene f3 = sceneAtFrame(templ, 3);
    expectNear(f3.camera.from, make_float3(2, 0, 5), 0.0f);
    EXPECT_FLOAT_EQ(f3.camera.fov, 30.0f);
    EXPECT_FALSE(f3.camera.hasMotion);
    expectNear(f3.lights[0].position, make_float3(4, 4, 0), 0.0f);
    expectNear(f3.volumes[0].transform, Transform::translate(0, 1, 0), 0.0);
    EXPECT_FALSE(f3.camera.fromKeys.animated() || f3.camera.fovKeys.animated() ||
                 f3.lights[0].positionKeys.animated() || f3.volumes[0].transformKeys.animated());
    // The frame's scene is static: its JSON has plain values (the volume cache keys on it).
    const json written = sceneToJson(f3);
    EXPECT_TRUE(written["camera"]["from"].front().is_number());
    EXPECT_EQ(written["volumes"][0]["transform"].size(), 16u);

    // Shutter [0, 0.5] at frame 2: the camera from frame 2 to frame 2.5; the rest at 2.25.
    Scene blurred = templ;
    blurred.camera.shutterOpen = 0.0f, blurred.camera.shutterClose = 0.5f;
    const Scene f2 = sceneAtFrame(blurred, 2);
    EXPECT_TRUE(f2.camera.hasMotion);
    expectNear(f2.camera.from, make_float3(1, 0, 5), 0.0f);
    expectNear(f2.camera.fromClose, make_float3(1.5f, 0, 5), 0.0f);
    expectNear(f2.camera.toClose, make_float3(0, 0, 0), 0.0f);
    EXPECT_FLOAT_EQ(f2.camera.fov, 40.0f - 5.0f * 1.25f);
    // The fov zooms within the shutter: its knots at 2 and 2.5 (camera.h).
    ASSERT_EQ(f2.camera.fovShutterMotion.frames.size(), 2u);
    EXPECT_FLOAT_EQ(f2.camera.fovShutterMotion.values[0], 40.0f - 5.0f * 1.0f);
    EXPECT_FLOAT_EQ(f2.camera.fovShutterMotion.values[1], 40.0f - 5.0f * 1.5f);
    expectNear(f2.lights[0].position, make_float3(2.5f, 4, 0), 1e-6f);
    // A frame's scene is a fixed point: evaluating it again changes nothing.
    EXPECT_EQ(sceneToJson(sceneAtFrame(f2, 2)), sceneToJson(f2));
}

}  // namespace
}  // namespace nimbus
