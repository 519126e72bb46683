// The camera's OpenEXR matrices (src/scene/CameraMatrices.h) against the rays the renderer
// shoots (kernels/shared/camera.h): a point on the ray through pixel (px, py) projects with
// worldToNDC to (px / width, py / height), and worldToCamera puts it on +z at its distance.
#include "scene/CameraMatrices.h"
#include "scene/KernelScene.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nimbus;

namespace {

float3 transformPoint(const Matrix44& m, float3 p, float* w = nullptr)
{
    const double in[4] = {p.x, p.y, p.z, 1.0};
    double out[4] = {0, 0, 0, 0};
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i)
            out[j] += in[i] * double(m[i * 4 + j]);
    if (w)
        *w = float(out[3]);
    return make_float3(float(out[0] / out[3]), float(out[1] / out[3]), float(out[2] / out[3]));
}

}  // namespace

TEST(CameraMatrices, PixelRaysProjectBackToTheirPixels)
{
    Camera camera;
    camera.from = make_float3(3.0f, 2.0f, -4.0f);
    camera.to = make_float3(-0.5f, 0.3f, 1.0f);
    camera.up = make_float3(0.1f, 1.0f, 0.2f);
    camera.fov = 35.0f;
    camera.width = 320;
    camera.height = 180;
    const NbCamera k = makeNbCamera(camera);
    const Matrix44 toCamera = worldToCameraMatrix(camera);
    const Matrix44 toNdc = worldToNdcMatrix(camera);
    for (float px : {0.0f, 17.25f, 160.0f, 319.5f})
        for (float py : {0.0f, 90.0f, 133.75f, 180.0f})
            for (float t : {0.5f, 4.0f, 300.0f}) {
                float3 origin, dir;
                nbCameraRay(k, px, py, camera.width, camera.height, 0.0f, &origin, &dir);
                const float3 p = origin + dir * t;
                const float3 ndc = transformPoint(toNdc, p);
                EXPECT_NEAR(ndc.x * camera.width, px, 2e-3f * (1.0f + t)) << px << "," << py << " t " << t;
                EXPECT_NEAR(ndc.y * camera.height, py, 2e-3f * (1.0f + t)) << px << "," << py << " t " << t;
                const float3 c = transformPoint(toCamera, p);
                EXPECT_GT(c.z, 0.0f) << "in front of the camera is +z";
                EXPECT_NEAR(length(c), t, 1e-4f * (1.0f + t)) << "worldToCamera is rigid";
            }
}

TEST(CameraMatrices, CameraSpaceAxes)
{
    Camera camera;  // from (0, 0, 5) looking at the origin, y up
    const Matrix44 m = worldToCameraMatrix(camera);
    const float3 right = transformPoint(m, make_float3(1, 0, 0));
    const float3 up = transformPoint(m, make_float3(0, 1, 0));
    const float3 ahead = transformPoint(m, make_float3(0, 0, 0));
    EXPECT_NEAR(right.x, 1.0f, 1e-6f);  // +x right
    EXPECT_NEAR(right.z, 5.0f, 1e-6f);
    EXPECT_NEAR(up.y, 1.0f, 1e-6f);     // +y up
    EXPECT_NEAR(ahead.z, 5.0f, 1e-6f);  // +z the viewing direction (left-handed, OpenEXR)
}
