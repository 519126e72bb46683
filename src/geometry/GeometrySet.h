// GeometrySet.h: the scene's geometry (docs/geometry.md) loaded and placed in world space, the one
// description every tracer of it reads: Embree for the CPU integrators (EmbreeScene.h) and
// the path tracer's own BVH (KernelBvh.h), which flattens the same arrays.
//
// Representation, per object type:
// - mesh: its file's triangles, transformed to world space once.
// - plane with a size: two triangles, exact (a rectangle is two triangles).
// - sphere: analytic, the quadric |objectFromWorld x| = radius (an ellipsoid under a non-uniform
//   scale). Tessellating it would cost n^2 triangles for a silhouette and hit depth off by
//   r (1 - cos(pi / n)) (5e-4 r at n = 100), and the holdout tests compare silhouettes and
//   depths to the pixel; the exact test is one quadratic, as cheap on the GPU as on the CPU.
// - plane without a size (infinite): analytic, a point and a normal. No finite triangle can
//   stand in for it (a quad 10^6 m wide puts the hit depth's rounding at centimetres), and no
//   BVH holds an unbounded primitive: tracers test the few infinite planes after the BVH.
// Every object keeps its flags (holdout: camera rays stop at it; shadows: it blocks light).
#pragma once

#include "../core/Transform.h"
#include "../core/Vec.h"
#include "../scene/Scene.h"

#include <cstdint>
#include <string>
#include <vector>

namespace nimbus {

struct GeometryObject {
    std::string name;
    GeometryType type = GeometryType::Mesh;
    bool holdout = true, shadows = true;
    // Triangles [firstTriangle, firstTriangle + triangleCount) of the set (meshes, sized planes).
    uint32_t firstTriangle = 0, triangleCount = 0;
    int32_t sphere = -1;  // index into spheres(), or -1
    int32_t plane = -1;   // index into infinitePlanes(), or -1
    Bbox bounds;          // world space; empty for an infinite plane
    size_t memoryBytes = 0;  // its share of the arrays below
};

// The quadric of a sphere object: x is on it where |objectFromWorld x| = radius.
struct SphereShape {
    Transform objectFromWorld;
    float radius = 1.0f;
    uint32_t object = 0;  // index into objects()
    Bbox bounds;          // world space
};

// Points x with dot(x - point, normal) = 0.
struct InfinitePlane {
    float3 point, normal;  // world space; normal unit
    uint32_t object = 0;
};

// The first t > tNear along o + t d (d any length; t in its units) where the ray meets the
// sphere, or INFINITY. In double: the quadratic's cancellation costs float half its digits.
float intersectSphere(const SphereShape& s, float3 o, float3 d, float tNear, float tFar);
// The same for an infinite plane.
float intersectPlane(const InfinitePlane& p, float3 o, float3 d, float tNear, float tFar);

class GeometrySet {
public:
    // Loads and places scene.geometry (meshes through MeshFile.h). Throws InputError naming the
    // scene file and the object's key; warns about an object that is neither a holdout nor a
    // shadow caster (it changes nothing). An empty scene.geometry gives an empty set, read from
    // no file.
    static GeometrySet load(const Scene& scene);

    bool empty() const { return mObjects.empty(); }
    const std::vector<GeometryObject>& objects() const { return mObjects; }
    // World-space vertex positions, x y z packed (12 bytes each), with one float of padding at
    // the end (Embree reads vertex buffers 16 bytes at a time).
    const std::vector<float>& vertices() const { return mVertices; }
    size_t vertexCount() const { return (mVertices.size() - (mVertices.empty() ? 0 : 1)) / 3; }
    // Three indices into vertices() per triangle, objects' triangles contiguous and in order.
    const std::vector<uint32_t>& indices() const { return mIndices; }
    size_t triangleCount() const { return mIndices.size() / 3; }
    const std::vector<SphereShape>& spheres() const { return mSpheres; }
    const std::vector<InfinitePlane>& infinitePlanes() const { return mPlanes; }
    size_t memoryBytes() const;

    // Appends an object made in code (tests, tools): triangles in world space.
    void addTriangles(const std::string& name, const std::vector<float3>& positions,
                      const std::vector<uint32_t>& indices, bool holdout, bool shadows);

private:
    void addObject(const Scene& scene, size_t index);

    std::vector<GeometryObject> mObjects;
    std::vector<float> mVertices;
    std::vector<uint32_t> mIndices;
    std::vector<SphereShape> mSpheres;
    std::vector<InfinitePlane> mPlanes;
};

}  // namespace nimbus
