// TileCulling.h: image tiles whose primary rays cannot meet the volumes, found before any ray
// is traced. A typical frame frames a cloud with sky around it: those tiles are background
// (renderMarched writes them without tracing).
#pragma once

#include "../../kernels/shared/camera.h"
#include "../core/Vec.h"

namespace nimbus {

// True where no primary ray through pixels [x0, x1) x [y0, y1) can meet `box`: the box lies
// wholly outside one of the four planes through the eye that bound the tile's rays, or behind
// the eye (every ray's direction has a positive forward part). Pixel jitter keeps rays inside
// their pixels; a pixel of margin on each side covers rounding. A moving camera sweeps its
// frustum over the shutter, so it is never culled.
inline bool tileMissesBox(const NbCamera& cam, int width, int height, int x0, int y0, int x1, int y1, const Bbox& box)
{
    if (cam.hasMotion > 0.5f)
        return false;
    if (!(box.lo.x <= box.hi.x && box.lo.y <= box.hi.y && box.lo.z <= box.hi.z))
        return true;  // no volume: every ray misses
    const float3 o = nbLoad3(cam.originOpen), f = nbLoad3(cam.forwardOpen), r = nbLoad3(cam.rightOpen);
    const float3 u = cross(r, f);
    const double sx0 = (2.0 * (x0 - 1) / width - 1.0) * cam.tanHalfFov * cam.aspect;
    const double sx1 = (2.0 * (x1 + 1) / width - 1.0) * cam.tanHalfFov * cam.aspect;
    const double sy0 = (1.0 - 2.0 * (y1 + 1) / height) * cam.tanHalfFov;  // y runs down the image
    const double sy1 = (1.0 - 2.0 * (y0 - 1) / height) * cam.tanHalfFov;
    bool left = true, right = true, below = true, above = true, behind = true;
    for (int i = 0; i < 8; ++i) {
        const float3 c = make_float3(i & 1 ? box.hi.x : box.lo.x, i & 2 ? box.hi.y : box.lo.y, i & 4 ? box.hi.z : box.lo.z);
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

}  // namespace nimbus
