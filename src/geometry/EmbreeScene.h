// EmbreeScene.h: the scene's geometry as Embree 3 scenes, the CPU integrators' ray queries against
// it (docs/geometry.md). One per render, built once from a GeometrySet, then read concurrently.
//
// Two sets of rays, two Embree scenes: camera rays meet the holdouts, light rays the shadow
// casters (an object may be one, the other or both). Where every object is both, one scene
// serves both. Triangles share the GeometrySet's arrays (no copy); spheres are Embree user
// geometry with the exact quadric (GeometrySet.h); infinite planes, which no BVH bounds, are
// tested after the traversal. A scene without geometry makes none of this: the render context
// holds no EmbreeScene and no Embree device is created (a scene without geometry costs nothing).
#pragma once

#include "GeometrySet.h"

#include <memory>

namespace nimbus {

class EmbreeScene {
public:
    // Builds the device and the BVHs (Embree's own TBB threads). Throws Error where Embree fails.
    explicit EmbreeScene(GeometrySet geometry);
    ~EmbreeScene();
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;

    const GeometrySet& geometry() const { return mGeometry; }
    bool hasHoldouts() const { return mHoldouts.any; }
    bool hasShadowCasters() const { return mShadows.any; }

    // Camera rays: the distance t in (0, tFar) to the first holdout along o + t d (d unit, world
    // space), or INFINITY.
    float holdoutHit(float3 o, float3 d, float tFar = INFINITY) const;
    // The same for n rays at once, eight at a time (rtcIntersect8: a tile row's neighbouring
    // rays share most of their traversal).
    void holdoutHits(int n, const float3* o, const float3* d, float* t) const;
    // Light rays: the first shadow caster in (tNear, tFar), or INFINITY (deep shadow map texels
    // need where the shadow starts); and whether there is any (shadow rays, any hit).
    float shadowHit(float3 o, float3 d, float tNear, float tFar) const;
    bool occluded(float3 o, float3 d, float tNear, float tFar) const;

    double buildSeconds() const { return mBuildSeconds; }
    // Embree's allocations (BVHs, its copies), measured by its memory monitor; the triangle
    // arrays themselves are geometry().memoryBytes().
    size_t bvhBytes() const;

    struct Impl;  // the Embree handles (EmbreeScene.cpp)

private:
    struct RaySet {
        bool any = false;
        void* scene = nullptr;         // RTCScene; null where no triangle or sphere is in the set
        std::vector<uint32_t> planes;  // infinite planes in the set
    };
    float firstHit(const RaySet& set, float3 o, float3 d, float tNear, float tFar) const;

    GeometrySet mGeometry;
    std::unique_ptr<Impl> mImpl;
    RaySet mHoldouts, mShadows;
    double mBuildSeconds = 0.0;
};

}  // namespace nimbus
