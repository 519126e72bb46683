// CameraMatrices.h: the camera as the two OpenEXR standard header matrices, so that a compositor
// can place 3D points over the render (OpenEXR ImfStandardAttributes.h, "worldToCamera",
// "worldToNDC").
//
// Both use OpenEXR's row-vector convention, p' = p M with p = (x, y, z, 1), stored row-major.
// Camera space is OpenEXR's (RenderMan's): left-handed, origin at the eye, +x right, +y up, +z the
// viewing direction. NDC is the image plane with (0, 0) at the display window's top-left corner
// and (1, 1) at its bottom-right: p M = (X, Y, Z, W), NDC = (X / W, Y / W), Z / W = 1 / z_camera
// (OpenEXR discards it). Pixel (px, py) of a width x height frame is NDC (px / width,
// py / height), exactly the ray kernels/shared/camera.h shoots through that pixel.
// With motion blur the matrices are the camera at shutter open.
#pragma once

#include "Scene.h"

#include <array>

namespace nimbus {

using Matrix44 = std::array<float, 16>;  // row-major, row vectors: p' = p M

Matrix44 worldToCameraMatrix(const Camera& camera);
Matrix44 worldToNdcMatrix(const Camera& camera);

}  // namespace nimbus
