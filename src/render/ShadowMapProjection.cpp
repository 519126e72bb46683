// ShadowMapProjection.cpp: where a deep shadow map's texels look (DeepShadowMap.h): the faces
// placed for a light (orthographic for distant lights, perspective for narrow spots, a cube of six
// perspective faces for point lights and wide spots), a texel's ray, and the projection of a world
// point onto a face. Separate from the build and the lookups, which both go through it.
#include "DeepShadowMap.h"

#include "../core/Error.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

namespace {

// Cube faces: forward axes +x, -x, +y, -y, +z, -z with right/up completing a right-handed frame.
const float3 kCubeForward[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
const float3 kCubeUp[6] = {{0, 1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};

// Perspective maps wider than this half-angle use a cube instead (texel stretch grows as
// 1/cos^2 of the off-axis angle).
constexpr float kMaxPerspectiveHalfAngleDeg = 60.0f;

}  // namespace

void DeepShadowMap::placeFaces(const NbLight& light, const VolumeSet& volumes)
{
    const Bbox& bounds = volumes.worldBounds();
    if (light.type == NB_LIGHT_DISTANT) {
        mProjection = Projection::Orthographic;
        Face f;
        f.forward = normalize(nbLoad3(light.direction));
        nbBasis(f.forward, &f.right, &f.up);
        float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
        for (int i = 0; i < 8; ++i) {
            float3 c = make_float3(i & 1 ? bounds.hi.x : bounds.lo.x, i & 2 ? bounds.hi.y : bounds.lo.y,
                                   i & 4 ? bounds.hi.z : bounds.lo.z);
            float q[3] = {dot(c, f.right), dot(c, f.up), dot(c, f.forward)};
            for (int a = 0; a < 3; ++a)
                lo[a] = std::min(lo[a], q[a]), hi[a] = std::max(hi[a], q[a]);
        }
        // Texels finer than the density grid resolve nothing the grid holds: cap the resolution
        // at 0.75 of the finest voxel across the footprint (the fewest texels that meet the
        // grid, DESIGN "leave out what a scene does not need"); `resolution` is the maximum.
        float side = std::max(std::max(hi[0] - lo[0], hi[1] - lo[1]), 1e-6f);
        mRes = std::max(8, std::min(mRes, int(std::ceil(side / (0.75f * volumes.minVoxelSize())))));
        // A square footprint with a margin of one texel on each side (clamp-to-edge lookups).
        side *= 1.0f + 2.0f / float(mRes);
        float cr = 0.5f * (lo[0] + hi[0]), cu = 0.5f * (lo[1] + hi[1]);
        float depth0 = lo[2] - 0.01f * (hi[2] - lo[2]) - 1e-6f;
        f.origin = f.right * (cr - 0.5f * side) + f.up * (cu - 0.5f * side) + f.forward * depth0;
        f.extent = side;
        mFaces.push_back(f);
    } else if (light.type == NB_LIGHT_SPOT &&
               std::acos(std::min(1.0f, std::max(-1.0f, light.p0))) < kMaxPerspectiveHalfAngleDeg * M_PI / 180.0) {
        mProjection = Projection::Perspective;
        Face f;
        f.origin = nbLoad3(light.position);
        f.forward = normalize(nbLoad3(light.direction));
        nbBasis(f.forward, &f.right, &f.up);
        float halfAngle = std::acos(std::min(1.0f, std::max(-1.0f, light.p0)));
        // One extra texel of footprint so bilinear lookups at the cone edge stay inside.
        f.extent = std::tan(halfAngle) * (1.0f + 2.0f / float(mRes));
        mFaces.push_back(f);
    } else if (light.type == NB_LIGHT_POINT || light.type == NB_LIGHT_SPOT) {
        mProjection = Projection::Cube;
        for (int i = 0; i < 6; ++i) {
            Face f;
            f.origin = nbLoad3(light.position);
            f.forward = kCubeForward[i];
            f.up = kCubeUp[i];
            f.right = cross(f.forward, f.up);
            f.extent = 1.0f;
            mFaces.push_back(f);
        }
    } else {
        throw Error("deep shadow maps are built for distant, point and spot lights only");
    }
}

void DeepShadowMap::texelRay(int face, float u, float v, float3& o, float3& d) const
{
    const Face& f = mFaces[face];
    if (mProjection == Projection::Orthographic) {
        o = f.origin + f.right * (u * f.extent) + f.up * (v * f.extent);
        d = f.forward;
    } else {
        o = f.origin;
        d = normalize(f.forward + f.right * ((2.0f * u - 1.0f) * f.extent) + f.up * ((2.0f * v - 1.0f) * f.extent));
    }
}

bool DeepShadowMap::project(float3 p, int& face, float& u, float& v, float& z) const
{
    if (mProjection == Projection::Orthographic) {
        const Face& f = mFaces[0];
        float3 q = p - f.origin;
        face = 0;
        u = dot(q, f.right) / f.extent;
        v = dot(q, f.up) / f.extent;
        z = dot(q, f.forward);
        return true;
    }
    float3 q = p - mFaces[0].origin;
    if (mProjection == Projection::Cube) {
        float ax = std::fabs(q.x), ay = std::fabs(q.y), az = std::fabs(q.z);
        face = ax >= ay && ax >= az ? (q.x >= 0 ? 0 : 1) : (ay >= az ? (q.y >= 0 ? 2 : 3) : (q.z >= 0 ? 4 : 5));
    } else {
        face = 0;
    }
    const Face& f = mFaces[face];
    float zf = dot(q, f.forward);
    if (!(zf > 0.0f))
        return false;
    u = 0.5f * (dot(q, f.right) / (zf * f.extent) + 1.0f);
    v = 0.5f * (dot(q, f.up) / (zf * f.extent) + 1.0f);
    z = length(q);
    return true;
}

}  // namespace nimbus
