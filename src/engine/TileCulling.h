// TileCulling.h: image tiles whose primary rays cannot meet the volumes, found before any ray
// is traced. A typical frame frames a cloud with sky around it: those tiles are background
// (the tile driver writes them without tracing).
#pragma once

#include "../../kernels/shared/camera.h"
#include "../core/Vec.h"
#include "../volume/OccupiedBricks.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace nimbus {

// The culling margin, pixels, for a pixel filter of full width `filterWidth`: rays leave their
// pixel by up to filterWidth / 2 - 1/2, and one more pixel covers rounding.
inline double filterMargin(float filterWidth)
{
    return 1.0 + std::max(0.0, 0.5 * double(filterWidth) - 0.5);
}

// The least and largest tan(fov/2) of the camera over the shutter: a zoom's fov is linear in
// angle between its knots (camera.h), so its extremes are knots. A still fov: both tanHalfFov.
inline void tanHalfFovRange(const NbCamera& cam, double& lo, double& hi)
{
    lo = hi = double(cam.tanHalfFov);
    for (int i = 0; i < int(cam.fovKnots); ++i) {
        const double t = std::tan(double(cam.fovHalf[i]));
        lo = std::min(lo, t), hi = std::max(hi, t);
    }
}

// True where no primary ray through pixels [x0, x1) x [y0, y1) can meet `box`: the box lies
// wholly outside one of the four planes through the eye that bound the tile's rays, or behind
// the eye (every ray's direction has a positive forward part). The pixel filter spreads a pixel's
// rays up to its radius r from the pixel's centre; `margin` pixels on each side (filterMargin:
// r - 1/2 past the pixel, plus one for rounding) cover them. A moving camera sweeps its frustum
// over the shutter, so it is never culled. A zoom (fov knots) scales the tile's image-plane
// rectangle by tan(fov/2) over [lo, hi]: each of its edges is linear in that scale, so the
// rectangle spanned by its edges at lo and at hi holds every ray of the shutter.
inline bool tileMissesBox(const NbCamera& cam, int width, int height, int x0, int y0, int x1, int y1, const Bbox& box,
                          double margin)
{
    if (cam.hasMotion > 0.5f)
        return false;
    if (!(box.lo.x <= box.hi.x && box.lo.y <= box.hi.y && box.lo.z <= box.hi.z))
        return true;  // no volume: every ray misses
    const float3 o = nbLoad3(cam.originOpen), f = nbLoad3(cam.forwardOpen), r = nbLoad3(cam.rightOpen);
    const float3 u = cross(r, f);
    double lo, hi;
    tanHalfFovRange(cam, lo, hi);
    const double ax0 = 2.0 * (x0 - margin) / width - 1.0, ax1 = 2.0 * (x1 + margin) / width - 1.0;
    const double ay0 = 1.0 - 2.0 * (y1 + margin) / height;  // y runs down the image
    const double ay1 = 1.0 - 2.0 * (y0 - margin) / height;
    const double sx0 = std::min(ax0 * lo, ax0 * hi) * cam.aspect, sx1 = std::max(ax1 * lo, ax1 * hi) * cam.aspect;
    const double sy0 = std::min(ay0 * lo, ay0 * hi), sy1 = std::max(ay1 * lo, ay1 * hi);
    bool left = true, right = true, below = true, above = true, behind = true;
    for (int i = 0; i < 8; ++i) {
        const float3 c =
            make_float3(i & 1 ? box.hi.x : box.lo.x, i & 2 ? box.hi.y : box.lo.y, i & 4 ? box.hi.z : box.lo.z);
        const float3 q = c - o;
        const double cx = dot(q, r), cy = dot(q, u), cz = dot(q, f);
        left = left && cx < sx0 * cz;
        right = right && cx > sx1 * cz;
        below = below && cy < sy0 * cz;
        above = above && cy > sy1 * cz;
        behind = behind && cz <= 0.0;
    }
    return left || right || below || above || behind;
}

// floor(v) clamped to [lo, hi] in double, then converted: never outside int, NaN gives lo for a
// first index and hi for a last one (lo <= hi callers pass as (0, n) and (-1, n - 1)).
inline int tileIndex(double v, int lo, int hi)
{
    if (std::isnan(v))
        return lo < 0 ? hi : lo;
    return int(std::clamp(std::floor(v), double(lo), double(hi)));
}

// Finer than the bounding box: marks in `seen` (tilesX x tilesY tiles of `tile` pixels, the
// first at pixel (fx0, fy0)) every tile whose rays could meet an occupied brick of `grid`
// (positive majorant), placed by worldFromIndex. Each brick's trilinear support, index box
// [origin, origin + 8]^3 (apron included), is convex, so with every corner in front of the eye
// its image lies inside the bounding rectangle of its corners' images; that rectangle, a pixel
// wider on each side (jitter, rounding), marks the tiles it overlaps. Returns false, marking
// nothing more, where some brick reaches to or behind the eye's plane (the caller then keeps
// every tile) or the camera moves. A cloud in its bounding box leaves the box's corners empty:
// those rays no longer walk bricks to find nothing. `margin` as for tileMissesBox. A zoom: a
// corner's pixel is linear in 1 / tan(fov/2), so its images at the least and largest
// tan(fov/2) bound where it goes over the shutter.
inline bool markTilesSeeingBricks(const NbCamera& cam, int width, int height, int fx0, int fy0, int tile, int tilesX,
                                  int tilesY, const BrickGrid& grid, const Transform& worldFromIndex,
                                  std::vector<char>& seen, double margin)
{
    if (cam.hasMotion > 0.5f)
        return false;
    const float3 o = nbLoad3(cam.originOpen), f = nbLoad3(cam.forwardOpen), r = nbLoad3(cam.rightOpen);
    const float3 u = cross(r, f);
    double tanLo, tanHi;
    tanHalfFovRange(cam, tanLo, tanHi);
    const double tans[2] = {tanLo, tanHi};
    return forEachOccupiedBrick(grid, worldFromIndex, [&](const float3* corners) {
        double pxLo = 1e300, pxHi = -1e300, pyLo = 1e300, pyHi = -1e300;
        for (int i = 0; i < 8; ++i) {
            const float3 q = corners[i] - o;
            const double cz = dot(q, f);
            if (!(cz > 1e-6 * double(length(q))))
                return false;  // at or behind the eye's plane: no bounded image
            for (double tanHalfFov : tans) {
                const double kx = 0.5 * width / (tanHalfFov * cam.aspect), ky = 0.5 * height / tanHalfFov;
                const double px = (double(dot(q, r)) / cz) * kx + 0.5 * width;
                const double py = 0.5 * height - (double(dot(q, u)) / cz) * ky;  // y runs down the image
                pxLo = std::min(pxLo, px), pxHi = std::max(pxHi, px);
                pyLo = std::min(pyLo, py), pyHi = std::max(pyHi, py);
            }
        }
        // Pixels [floor(lo - margin), hi + margin] hold every ray that can pass the rectangle.
        const double x0 = std::floor(pxLo - margin) - fx0, x1 = pxHi + margin - fx0;
        const double y0 = std::floor(pyLo - margin) - fy0, y1 = pyHi + margin - fy0;
        // Clamped in double before the conversion: at a tiny field of view (fov 1e-10) a brick's
        // image spans 1e14 pixels, beyond int, and int() of it was undefined (issue 18, failure
        // 4: tile indices wrapped negative and the loop wrote out of bounds). NaN marks all.
        const int tx0 = tileIndex(x0 / tile, 0, tilesX), tx1 = tileIndex(x1 / tile, -1, tilesX - 1);
        const int ty0 = tileIndex(y0 / tile, 0, tilesY), ty1 = tileIndex(y1 / tile, -1, tilesY - 1);
        for (int ty = ty0; ty <= ty1; ++ty)
            for (int tx = tx0; tx <= tx1; ++tx)
                seen[size_t(ty) * tilesX + tx] = 1;
        return true;
    });
}

}  // namespace nimbus
