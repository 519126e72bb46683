// Transform and light motion within the shutter (issue 16, item 2; kernels/shared/motion.h,
// docs/motion-blur.md "Transform and light motion"): the knots a frame's scene keeps, and the
// shared float interpolation (used by the OpenCL path tracer, vrl, single and wkb) against the
// animation's own double-precision evaluation (Animation.h) at every shutter time; the set's
// swept bounds hold the volume at every time; a moving volume is read through its transform at
// the sample's time.
#include "HandMadeVolume.h"
#include "render/VolumeSet.h"
#include "scene/Animation.h"
#include "scene/FrameTokens.h"
#include "scene/KernelScene.h"
#include "core/Error.h"

#include <gtest/gtest.h>

#include <cmath>

namespace nimbus {
namespace {

constexpr float kFps = 24.0f;

Keys<Transform> transformKeys()
{
    // A turn of 120 degrees about a tilted axis, a move and a growth over two frames, with a key
    // in the middle (the shutter holds it), and a mirror in every key (negative x scale).
    Keys<Transform> k;
    k.frames = {1.0, 2.0, 3.0};
    k.values = {Transform::translate(0, 0, 0) * Transform::scale(-1, 1, 1),
                Transform::translate(1, 0.5, 0) * Transform::rotateDegrees(70, 0.3, 1, 0.2) * Transform::scale(-1.5, 1.5, 2),
                Transform::translate(1.5, 1, -1) * Transform::rotateDegrees(120, 0.3, 1, 0.2) * Transform::scale(-2, 1, 2)};
    return k;
}

Scene movingScene()
{
    Scene s;
    s.render.frame = 2;
    s.render.fps = kFps;
    s.camera.shutterOpen = -0.75f, s.camera.shutterClose = 0.5f;
    Volume v;
    v.transformKeys = transformKeys();
    s.volumes.push_back(v);
    Light spot;
    spot.type = LightType::Spot;
    spot.positionKeys.frames = {1.0, 1.5, 4.0};
    spot.positionKeys.values = {make_float3(0, 4, 0), make_float3(2, 4, 1), make_float3(2, 6, 5)};
    spot.directionKeys.frames = {0.0, 3.0};
    spot.directionKeys.values = {make_float3(0, -1, 0), make_float3(1, -1, 0.5f)};
    s.lights.push_back(spot);
    Light rect;
    rect.type = LightType::Rect;
    rect.size[0] = 2, rect.size[1] = 0.5f;
    rect.normalKeys.frames = {1.0, 3.0};
    rect.normalKeys.values = {make_float3(0, -1, 0), make_float3(0.5f, -1, 0.2f)};
    rect.upKeys.frames = {1.0, 3.0};
    rect.upKeys.values = {make_float3(0, 0, 1), make_float3(1, 0, 1)};
    s.lights.push_back(rect);
    Light still;  // keyed, but not moving within the shutter
    still.positionKeys.frames = {0.0, 1.0};
    still.positionKeys.values = {make_float3(0, 0, 0), make_float3(1, 0, 0)};
    s.lights.push_back(still);
    return s;
}

TEST(ShutterMotion, AFramesSceneKeepsTheKnotsOfWhatMovesWithinTheShutter)
{
    const Scene templ = movingScene();
    const Scene f = sceneAtFrame(templ, 2);
    // Shutter [1.25, 2.5]: open, the key at 2, close.
    const Keys<Transform>& v = f.volumes[0].shutterMotion;
    ASSERT_EQ(v.frames.size(), 3u);
    EXPECT_DOUBLE_EQ(v.frames[0], -0.75);
    EXPECT_DOUBLE_EQ(v.frames[1], 0.0);
    EXPECT_DOUBLE_EQ(v.frames[2], 0.5);
    for (size_t j = 0; j < 3; ++j)
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c)
                EXPECT_NEAR(v.values[j].at(r, c), evaluateKeys(templ.volumes[0].transformKeys, 2.0 + v.frames[j]).at(r, c),
                            1e-12);
    // The static transform is the shutter centre's (1.875).
    const Transform centre = evaluateKeys(templ.volumes[0].transformKeys, 1.875);
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            EXPECT_NEAR(f.volumes[0].transform.at(r, c), centre.at(r, c), 1e-12);
    // The spot: keys of both its channels inside the shutter (1.5) are knots.
    const auto& spot = f.lights[0].shutterMotion;
    ASSERT_EQ(spot.frames.size(), 3u);
    EXPECT_DOUBLE_EQ(spot.frames[1], -0.5);
    EXPECT_FLOAT_EQ(spot.values[1].position.x, 2.0f);
    EXPECT_TRUE(f.lights[2].shutterMotion.frames.empty());  // keyed, but still over [1.25, 2.5]
    // A frame's scene is a fixed point: evaluated again, its motion stays.
    const Scene again = sceneAtFrame(f, 2);
    EXPECT_EQ(again.volumes[0].shutterMotion.frames, v.frames);
    EXPECT_EQ(again.lights[0].shutterMotion.frames, spot.frames);
    // A closed shutter keeps none.
    Scene closed = templ;
    closed.camera.shutterOpen = closed.camera.shutterClose = 0.0f;
    const Scene fc = sceneAtFrame(closed, 2);
    EXPECT_TRUE(fc.volumes[0].shutterMotion.frames.empty());
    EXPECT_TRUE(fc.lights[0].shutterMotion.frames.empty());
}

TEST(ShutterMotion, TheKernelsTransformIsTheAnimationsAtEveryShutterTime)
{
    const Scene templ = movingScene();
    const Scene f = sceneAtFrame(templ, 2);
    // The grid's own index-to-world: 5 cm voxels, offset.
    const Transform fileFromIndex = Transform::translate(0.1, -0.2, 0.3) * Transform::scale(0.05, 0.05, 0.05);
    VolumeData data;
    data.worldFromIndex = f.volumes[0].transform * fileFromIndex;
    data.indexFromWorld = data.worldFromIndex.inverse();
    const std::vector<float> block = transformMotionBlock(f.volumes[0], data, kFps);
    ASSERT_EQ(block.size(), size_t(NB_MOTION_KNOT * 4));
    for (int n = 0; n <= 40; ++n) {
        const double frames = -0.75 + 1.25 * n / 40.0;  // after the frame
        float m[12];
        nbMotionIndexFromWorld(block.data(), 3, float(frames / kFps), m);
        const Transform want = (evaluateKeys(templ.volumes[0].transformKeys, 2.0 + frames) * fileFromIndex).inverse();
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                EXPECT_NEAR(m[4 * r + c], want.at(r, c), 2e-4 * (1.0 + std::fabs(want.at(r, c))))
                    << "frame " << 2.0 + frames << " row " << r << " col " << c;
    }
}

TEST(ShutterMotion, TheKernelsLightIsTheAnimationsAtEveryShutterTime)
{
    const Scene templ = movingScene();
    const Scene f = sceneAtFrame(templ, 2);
    for (size_t i = 0; i < 2; ++i) {
        const std::vector<float> knots = lightMotionKnots(f.lights[i], kFps);
        ASSERT_FALSE(knots.empty());
        const NbLight centre = makeNbLight(f.lights[i], int(i));
        for (int n = 0; n <= 30; ++n) {
            const double frames = -0.75 + 1.25 * n / 30.0;
            const NbLight got = nbLightAt(centre, knots.data(), int(knots.size() / NB_MOTION_KNOT), float(frames / kFps));
            // The light as the keys place it at that frame, converted as the frame's lights are.
            Light l = templ.lights[i];
            for (auto* k : {&l.positionKeys, &l.directionKeys, &l.normalKeys, &l.upKeys, &l.centerKeys})
                if (k->animated()) {
                    float3& value = k == &l.positionKeys    ? l.position
                                    : k == &l.directionKeys ? l.direction
                                    : k == &l.normalKeys    ? l.normal
                                    : k == &l.upKeys        ? l.up
                                                            : l.center;
                    value = evaluateKeys(*k, 2.0 + frames);
                }
            const NbLight want = makeNbLight(l, int(i));
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(got.position[c], want.position[c], 1e-5) << "light " << i << " frame " << 2 + frames;
                EXPECT_NEAR(got.direction[c], want.direction[c], 1e-5) << "light " << i << " frame " << 2 + frames;
                EXPECT_NEAR(got.axisU[c], want.axisU[c], 1e-5) << "light " << i << " frame " << 2 + frames;
                EXPECT_NEAR(got.axisV[c], want.axisV[c], 1e-5) << "light " << i << " frame " << 2 + frames;
            }
        }
    }
}

// The camera's fov zooming within the shutter (camera.h): the knots a frame keeps, and the
// rays' tan(fov/2) at every shutter time against the keys' own evaluation (linear in degrees).
TEST(ShutterMotion, TheCamerasFovIsTheAnimationsAtEveryShutterTime)
{
    Scene templ = movingScene();
    templ.camera.fovKeys.frames = {1.0, 1.5, 2.25, 4.0};
    templ.camera.fovKeys.values = {30.0f, 45.0f, 20.0f, 60.0f};
    const Scene f = sceneAtFrame(templ, 2);
    // Shutter [1.25, 2.5]: open, the keys at 1.5 and 2.25, close.
    const Keys<float>& k = f.camera.fovShutterMotion;
    ASSERT_EQ(k.frames.size(), 4u);
    EXPECT_DOUBLE_EQ(k.frames[0], -0.75);
    EXPECT_DOUBLE_EQ(k.frames[1], -0.5);
    EXPECT_DOUBLE_EQ(k.frames[2], 0.25);
    EXPECT_DOUBLE_EQ(k.frames[3], 0.5);
    EXPECT_FLOAT_EQ(f.camera.fov, evaluateKeys(templ.camera.fovKeys, 1.875));  // the centre's
    EXPECT_EQ(sceneAtFrame(f, 2).camera.fovShutterMotion.frames, k.frames);    // a fixed point
    const NbCamera cam = makeNbCamera(f.camera);
    ASSERT_EQ(int(cam.fovKnots), 4);
    for (int n = 0; n <= 40; ++n) {
        const double u = n / 40.0;  // fraction of the shutter
        const double want = std::tan(double(evaluateKeys(templ.camera.fovKeys, 1.25 + 1.25 * u)) * M_PI / 360.0);
        EXPECT_NEAR(nbCameraTanHalfFov(cam, float(u)), want, 2e-6 * want) << "shutter fraction " << u;
    }
    // The ray through a pixel follows: the image-plane offset scales with tan(fov/2).
    float3 o, d0, d1;
    nbCameraRay(cam, 0.0f, 0.0f, 64, 64, 0.0f, &o, &d0);
    nbCameraRay(cam, 0.0f, 0.0f, 64, 64, 0.8f, &o, &d1);  // frame 2.25: the fov narrows to 20 degrees
    const float3 f0 = nbLoad3(cam.forwardOpen);
    EXPECT_LT(dot(d0, f0), dot(d1, f0));
    // Still fovs keep none: a closed shutter, keys that agree over the shutter.
    Scene closed = templ;
    closed.camera.shutterOpen = closed.camera.shutterClose = 0.0f;
    EXPECT_TRUE(sceneAtFrame(closed, 2).camera.fovShutterMotion.frames.empty());
    EXPECT_EQ(makeNbCamera(sceneAtFrame(closed, 2).camera).fovKnots, 0.0f);
    Scene flat = templ;
    flat.camera.fovKeys.values = {40.0f, 40.0f, 40.0f, 40.0f};
    EXPECT_TRUE(sceneAtFrame(flat, 2).camera.fovShutterMotion.frames.empty());
    // More keys within one shutter than the kernel holds: an input error naming camera.fov.
    Scene dense = templ;
    dense.camera.fovKeys = {};
    for (int j = 0; j <= 12; ++j) {
        dense.camera.fovKeys.frames.push_back(1.3 + 0.1 * j);
        dense.camera.fovKeys.values.push_back(30.0f + float(j));
    }
    try {
        sceneAtFrame(dense, 2);
        FAIL() << "expected an input error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("camera.fov"), std::string::npos) << e.what();
    }
}

TEST(ShutterMotion, AMovingVolumeIsReadThroughItsTransformAtTheSamplesTime)
{
    const Scene templ = movingScene();
    const Scene f = sceneAtFrame(templ, 2);
    // A 16^3 block of density 1 with 5 cm voxels, placed by the frame's (centre) transform.
    auto data = test::handMadeVolume(16, 0.05f, make_float3(-0.4f, -0.4f, -0.4f), [](int, int, int) { return 1.0f; });
    const Transform fileFromIndex = data->worldFromIndex;
    data->worldFromIndex = f.volumes[0].transform * fileFromIndex;
    data->indexFromWorld = data->worldFromIndex.inverse();
    data->worldBounds = data->worldFromIndex.box(data->density.activeIndexBounds());
    VolumeSet set({data}, 1.0f);
    Scene s = f;
    setShutterOf(set, s);
    ASSERT_TRUE(set.moving());
    const Bbox swept = set.movingBounds();
    const Bbox ib = data->density.activeIndexBounds();
    for (int n = 0; n <= 50; ++n) {
        const double frames = -0.75 + 1.25 * n / 50.0;
        const float seconds = float(frames / kFps);
        const Transform worldFromIndex = evaluateKeys(templ.volumes[0].transformKeys, 2.0 + frames) * fileFromIndex;
        // The swept box holds the volume's box at every time.
        const Bbox at = worldFromIndex.box(ib);
        auto axis = [](float3 v, int a) { return a == 0 ? v.x : (a == 1 ? v.y : v.z); };
        for (int a = 0; a < 3; ++a) {
            EXPECT_LE(axis(swept.lo, a), axis(at.lo, a)) << "frame " << 2 + frames;
            EXPECT_GE(axis(swept.hi, a), axis(at.hi, a)) << "frame " << 2 + frames;
        }
        // Inside the block at that time (its index centre): density 1, and the light point is
        // where that matter sits at the shutter centre (the maps' placement).
        const float3 centreIndex = make_float3(8, 8, 8);
        const float3 p = worldFromIndex.point(centreIndex);
        float3 lightPoint;
        std::vector<float> weights(1);
        std::vector<BrickGrid::Stencil> stencils(1);
        const MediumSample m = set.sampleAt(seconds, p, weights.data(), stencils.data(), &lightPoint);
        EXPECT_NEAR(m.sigma_t.x, data->sigmaT().x, 1e-4f) << "frame " << 2 + frames;
        const float3 want = data->worldFromIndex.point(centreIndex);
        EXPECT_NEAR(length(lightPoint - want), 0.0f, 1e-4f) << "frame " << 2 + frames;
        // Just outside it (a voxel and a half beyond a face, in index space): nothing.
        const float3 out = worldFromIndex.point(make_float3(-1.5f, 8, 8));
        EXPECT_EQ(set.sampleAt(seconds, out).sigma_t.x, 0.0f) << "frame " << 2 + frames;
        // The spans at that time cover the block along a ray through it.
        std::vector<Span> spans;
        const float3 o = p + make_float3(0, 0, 5), d = make_float3(0, 0, -1);
        set.spansAt(seconds, o, d, 0.0f, 10.0f, 0.5f, spans);
        ASSERT_FALSE(spans.empty());
        EXPECT_LT(spans.front().t0, 5.0f);
        EXPECT_GT(spans.back().t1, 5.0f);
    }
}

}  // namespace
}  // namespace nimbus
