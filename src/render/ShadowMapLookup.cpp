// ShadowMapLookup.cpp: the lookups in a deep shadow map's compressed vertices (DeepShadowMap.h):
// a texel's optical depth at a depth, found from the cursor's last vertex or by bisection, and
// the bilinear interpolation over the four nearest texels (RGB, and the grey light-cache form).
// The hot half of the map, kept apart from its build; the lookups in the kept march samples are
// in ShadowMapMarchSamples.h.
#include "DeepShadowMap.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

Rgb DeepShadowMap::lookup(uint32_t texel, uint32_t slot, float z, Cursor* cursor) const
{
    const uint32_t first = mOffsets[texel], last = mOffsets[texel + 1];
    if (first == last)
        return splat(0.0f);
    const Vertex* v = mVertices.data();
    if (z <= v[first].z)
        return splat(0.0f);
    if (z >= v[last - 1].z)
        return make_float3(v[last - 1].tau[0], v[last - 1].tau[1], v[last - 1].tau[2]);
    // Find i with v[i].z <= z < v[i+1].z: walk from the cursor's vertex for this texel, else
    // bisect.
    uint32_t i;
    uint32_t* slotVertex = nullptr;
    if (cursor) {
        slotVertex = &cursor->vertex[slot];
        if (cursor->texel[slot] != texel) {
            cursor->texel[slot] = texel;
            *slotVertex = ~0u;
        }
    }
    if (slotVertex && *slotVertex != ~0u) {
        i = *slotVertex;
        while (v[i + 1].z <= z)
            ++i;
        while (v[i].z > z)
            --i;
    } else {
        const Vertex* hi = std::upper_bound(v + first, v + last, z, [](float zz, const Vertex& x) { return zz < x.z; });
        i = uint32_t(hi - v) - 1;
    }
    if (slotVertex)
        *slotVertex = i;
    const Vertex& a = v[i];
    const Vertex& b = v[i + 1];
    float w = (z - a.z) / (b.z - a.z);
    return make_float3(a.tau[0] + w * (b.tau[0] - a.tau[0]), a.tau[1] + w * (b.tau[1] - a.tau[1]),
                       a.tau[2] + w * (b.tau[2] - a.tau[2]));
}

// lookup() for channel 0 with a cursor always present; inlined into the bilinear below.
inline float DeepShadowMap::greyLookup(uint32_t texel, uint32_t slot, float z, Cursor& cursor) const
{
    const uint32_t first = mOffsets[texel], last = mOffsets[texel + 1];
    const Vertex* v = mVertices.data();
    if (first == last || z <= v[first].z)
        return 0.0f;
    if (z >= v[last - 1].z)
        return v[last - 1].tau[0];
    uint32_t i = cursor.vertex[slot];
    if (cursor.texel[slot] != texel) {
        cursor.texel[slot] = texel;
        const Vertex* hi = std::upper_bound(v + first, v + last, z, [](float zz, const Vertex& x) { return zz < x.z; });
        i = uint32_t(hi - v) - 1;
    } else {
        while (v[i + 1].z <= z)
            ++i;
        while (v[i].z > z)
            --i;
    }
    cursor.vertex[slot] = i;
    const Vertex& a = v[i];
    const Vertex& b = v[i + 1];
    return a.tau[0] + (z - a.z) * (b.tau[0] - a.tau[0]) / (b.z - a.z);
}

float DeepShadowMap::greyOpticalDepthTexel(float fx, float fy, float z, Cursor& cursor) const
{
    const float last = float(mRes);
    if (!(fx >= -0.5f && fx <= last - 0.5f && fy >= -0.5f && fy <= last - 0.5f))
        return 0.0f;  // u or v outside [0, 1], as in opticalDepthAt
    const int x0 = floorToInt(fx), y0 = floorToInt(fy);
    const float wx = fx - float(x0), wy = fy - float(y0);
    const int xa = std::max(x0, 0), xb = std::min(x0 + 1, mRes - 1);
    const int ya = std::max(y0, 0), yb = std::min(y0 + 1, mRes - 1);
    const uint32_t ra = uint32_t(ya) * uint32_t(mRes), rb = uint32_t(yb) * uint32_t(mRes);
    const float a = greyLookup(ra + xa, Cursor::slot(xa, ya), z, cursor);
    const float b = greyLookup(ra + xb, Cursor::slot(xb, ya), z, cursor);
    const float c = greyLookup(rb + xa, Cursor::slot(xa, yb), z, cursor);
    const float d = greyLookup(rb + xb, Cursor::slot(xb, yb), z, cursor);
    const float lo = a + wx * (b - a), hi = c + wx * (d - c);
    return lo + wy * (hi - lo);
}

Rgb DeepShadowMap::texelOpticalDepth(int face, int ix, int iy, float z) const
{
    return lookup(uint32_t((size_t(face) * mRes + iy) * mRes + ix), 0, z, nullptr);
}

Rgb DeepShadowMap::opticalDepth(float3 p, Cursor* cursor) const
{
    int face;
    float u, v, z;
    if (!project(p, face, u, v, z))
        return splat(0.0f);
    return filteredOpticalDepthAt(face, u, v, z, cursor);
}

Rgb DeepShadowMap::filteredOpticalDepthAt(int face, float u, float v, float z, Cursor* cursor) const
{
    const float r = penumbraTexels(z);
    if (!(r >= kPenumbraMinTexels))
        return opticalDepthAt(face, u, v, z, cursor);
    const float s = r / float(mRes);
    Rgb T = splat(0.0f);
    for (int k = 0; k < kPenumbraTaps; ++k)
        T += exp(-opticalDepthAt(face, u + s * kPenumbraTapX[k], v + s * kPenumbraTapY[k], z, cursor));
    T = T * (1.0f / float(kPenumbraTaps));
    return make_float3(-std::log(std::max(T.x, 1e-30f)), -std::log(std::max(T.y, 1e-30f)),
                       -std::log(std::max(T.z, 1e-30f)));
}

Rgb DeepShadowMap::opticalDepthAt(int face, float u, float v, float z, Cursor* cursor) const
{
    if (mProjection != Projection::Cube && (u < 0.0f || u > 1.0f || v < 0.0f || v > 1.0f))
        return splat(0.0f);
    float fx = u * mRes - 0.5f, fy = v * mRes - 0.5f;
    int x0 = floorToInt(fx), y0 = floorToInt(fy);
    float wx = fx - x0, wy = fy - y0;
    auto clampI = [&](int i) { return std::min(std::max(i, 0), mRes - 1); };
    int xa = clampI(x0), xb = clampI(x0 + 1), ya = clampI(y0), yb = clampI(y0 + 1);
    const uint32_t base = uint32_t(face) * uint32_t(mRes) * uint32_t(mRes);
    Rgb tau = lookup(base + ya * mRes + xa, Cursor::slot(xa, ya), z, cursor) * ((1 - wx) * (1 - wy)) +
              lookup(base + ya * mRes + xb, Cursor::slot(xb, ya), z, cursor) * (wx * (1 - wy)) +
              lookup(base + yb * mRes + xa, Cursor::slot(xa, yb), z, cursor) * ((1 - wx) * wy) +
              lookup(base + yb * mRes + xb, Cursor::slot(xb, yb), z, cursor) * (wx * wy);
    return tau;
}

}  // namespace nimbus
