// HoldoutDepth.h: a depth-map holdout (Tessendorf sec. 8; docs/geometry.md): a camera-space depth
// image, read through OpenImageIO, that clips every camera sample at the depth found at its
// position on the image.
//
// Convention (the Z AOV of production renderers): per pixel the distance along the camera's
// view axis, metres, from the camera's position; infinity or 0 means nothing holds out there. A
// sample at image position (x, y) (pixels, the top-left corner at 0, y down, as the camera's
// rays) reads Z bilinearly between the four nearest pixel centres where all four hold a surface,
// else the nearest pixel's value: interpolating across a silhouette would invent depths between
// the surface and the sky. A ray of unit direction d then stops at t = Z / dot(d, forward).
#pragma once

#include "../scene/Scene.h"

#include <memory>
#include <vector>

namespace nimbus {

class HoldoutDepth {
public:
    // Reads scene.camera.holdout_depth for the camera's resolution: an image of another size is
    // an InputError unless its aspect ratio matches (within half a pixel), then it is resampled
    // by scaling its coordinates, with a warning. Throws InputError naming the scene file and key
    // for a missing or unreadable file, a missing channel, a negative or NaN depth. Null where
    // the camera has none.
    static std::unique_ptr<HoldoutDepth> load(const Scene& scene);
    // An image made in code (tests): width x height depths, row by row from the top.
    HoldoutDepth(int width, int height, std::vector<float> depth, int cameraWidth, int cameraHeight);

    // Z at image position (x, y) of the camera's image (pixels); INFINITY where nothing holds out
    // (kernels/shared/holdoutdepth.h, the path tracer's copy of the same lookup).
    float depthAt(float x, float y) const;
    // The image as the lookup reads it (INFINITY for none), and its pixels per camera pixel.
    const std::vector<float>& depths() const { return mDepth; }
    float scaleX() const { return mScaleX; }
    float scaleY() const { return mScaleY; }

    int width() const { return mWidth; }
    int height() const { return mHeight; }

private:
    int mWidth = 0, mHeight = 0;
    float mScaleX = 1.0f, mScaleY = 1.0f;  // this image's pixels per camera pixel
    std::vector<float> mDepth;             // INFINITY where nothing holds out
};

}  // namespace nimbus
