#include "CameraMatrices.h"

#include <cmath>

namespace nimbus {

namespace {

using Row = std::array<float, 4>;

Matrix44 rows(const Row& r0, const Row& r1, const Row& r2, const Row& r3)
{
    return {r0[0], r0[1], r0[2], r0[3], r1[0], r1[1], r1[2], r1[3],
            r2[0], r2[1], r2[2], r2[3], r3[0], r3[1], r3[2], r3[3]};
}

// C = A B for row-major 4x4 matrices (with row vectors: A first, then B).
Matrix44 multiply(const Matrix44& a, const Matrix44& b)
{
    Matrix44 c{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            double sum = 0.0;
            for (int k = 0; k < 4; ++k)
                sum += double(a[i * 4 + k]) * double(b[k * 4 + j]);
            c[i * 4 + j] = float(sum);
        }
    return c;
}

}  // namespace

Matrix44 worldToCameraMatrix(const Camera& c)
{
    // The frame of makeNbCamera (KernelScene.cpp): forward f, right r = f x up, up u = r x f.
    const float3 f = normalize(c.to - c.from);
    const float3 r = normalize(cross(f, c.up));
    const float3 u = cross(r, f);
    // Column j holds the axis whose coordinate p M gives: x_cam = (p - from) . r, and so on.
    return rows({r.x, u.x, f.x, 0.0f}, {r.y, u.y, f.y, 0.0f}, {r.z, u.z, f.z, 0.0f},
                {-dot(c.from, r), -dot(c.from, u), -dot(c.from, f), 1.0f});
}

Matrix44 worldToNdcMatrix(const Camera& c)
{
    // camera.h: a ray through pixel (px, py) has x_cam / z_cam = (2 px / width - 1) tan(fov/2)
    // aspect and y_cam / z_cam = (1 - 2 py / height) tan(fov/2). Solved for NDC = (px / width,
    // py / height): X = a x_cam + z_cam / 2, Y = -b y_cam + z_cam / 2, W = z_cam.
    const double tanHalfFov = std::tan(c.fov * M_PI / 360.0);
    const double aspect = double(c.width) / double(c.height);
    const float a = float(0.5 / (tanHalfFov * aspect));
    const float b = float(0.5 / tanHalfFov);
    const Matrix44 projection =
        rows({a, 0.0f, 0.0f, 0.0f}, {0.0f, -b, 0.0f, 0.0f}, {0.5f, 0.5f, 0.0f, 1.0f}, {0.0f, 0.0f, 1.0f, 0.0f});
    return multiply(worldToCameraMatrix(c), projection);
}

}  // namespace nimbus
