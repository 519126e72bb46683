/* holdoutdepth.h: reading a depth-map holdout (Tessendorf sec. 8; docs/geometry.md), shared by
 * the tile driver (src/geometry/HoldoutDepth.cpp) and the OpenCL path tracer.
 *
 * The image holds per pixel the camera-space depth Z (distance along the view axis, metres),
 * INFINITY where nothing holds out (the loader turns the file's 0 into INFINITY). A sample at
 * image position (x, y) of the camera's image (pixels, top-left corner 0, y down) reads Z
 * bilinearly between the four nearest pixel centres where all four hold a surface, else the value
 * of the pixel holding (x, y): interpolating across a silhouette would invent depths between the
 * surface and the sky. scaleX, scaleY: the image's pixels per camera pixel.
 */
#ifndef NIMBUS_KERNELS_SHARED_HOLDOUTDEPTH_H
#define NIMBUS_KERNELS_SHARED_HOLDOUTDEPTH_H

#include "compat.h"

NB_FN float nbHoldoutDepthTexel(const NB_GLOBAL float* depth, int width, int height, int ix, int iy)
{
    ix = ix < 0 ? 0 : (ix > width - 1 ? width - 1 : ix);
    iy = iy < 0 ? 0 : (iy > height - 1 ? height - 1 : iy);
    return depth[(nb_ulong)iy * (nb_ulong)width + (nb_ulong)ix];
}

NB_FN float nbHoldoutDepthAt(const NB_GLOBAL float* depth, int width, int height, float scaleX, float scaleY, float x,
                             float y)
{
    /* Pixel centres of the depth image at integers. */
    const float fx = x * scaleX - 0.5f, fy = y * scaleY - 0.5f;
    const int x0 = (int)floor(fx), y0 = (int)floor(fy);
    const float wx = fx - (float)x0, wy = fy - (float)y0;
    const float a = nbHoldoutDepthTexel(depth, width, height, x0, y0);
    const float b = nbHoldoutDepthTexel(depth, width, height, x0 + 1, y0);
    const float c = nbHoldoutDepthTexel(depth, width, height, x0, y0 + 1);
    const float d = nbHoldoutDepthTexel(depth, width, height, x0 + 1, y0 + 1);
    if (a < INFINITY && b < INFINITY && c < INFINITY && d < INFINITY) {
        const float top = a + wx * (b - a), bottom = c + wx * (d - c);
        return top + wy * (bottom - top);
    }
    return nbHoldoutDepthTexel(depth, width, height, (int)floor(x * scaleX), (int)floor(y * scaleY));
}

#endif
