#include "GeometrySet.h"

#include "MeshFile.h"

#include "../core/Error.h"
#include "../core/Log.h"

#include <cmath>
#include <limits>

namespace nimbus {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// x' = M x (+ translation where `point`), in double.
void apply(const Transform& m, const double x[3], bool point, double out[3])
{
    for (int r = 0; r < 3; ++r)
        out[r] = m.at(r, 0) * x[0] + m.at(r, 1) * x[1] + m.at(r, 2) * x[2] + (point ? m.at(r, 3) : 0.0);
}

}  // namespace

float intersectSphere(const SphereShape& s, float3 o, float3 d, float tNear, float tFar)
{
    const double ow[3] = {o.x, o.y, o.z}, dw[3] = {d.x, d.y, d.z};
    double p[3], v[3];
    apply(s.objectFromWorld, ow, true, p);
    apply(s.objectFromWorld, dw, false, v);
    // |p + t v|^2 = r^2, in the form that keeps its digits: t = -b/a -+ sqrt(r^2 - |p_perp|^2)/sqrt(a)
    // with p_perp the part of p normal to v (no b^2 - ac cancellation for distant spheres).
    const double a = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if (!(a > 0.0))
        return kInf;
    const double b = p[0] * v[0] + p[1] * v[1] + p[2] * v[2];
    const double tMid = -b / a;
    double perp2 = 0.0;
    for (int i = 0; i < 3; ++i) {
        const double q = p[i] + tMid * v[i];
        perp2 += q * q;
    }
    const double r2 = double(s.radius) * double(s.radius);
    if (perp2 > r2)
        return kInf;
    const double half = std::sqrt((r2 - perp2) / a);
    const double t0 = tMid - half, t1 = tMid + half;
    if (t0 > double(tNear) && t0 < double(tFar))
        return float(t0);
    if (t1 > double(tNear) && t1 < double(tFar))
        return float(t1);
    return kInf;
}

float intersectPlane(const InfinitePlane& p, float3 o, float3 d, float tNear, float tFar)
{
    const double dn = double(d.x) * p.normal.x + double(d.y) * p.normal.y + double(d.z) * p.normal.z;
    if (dn == 0.0)
        return kInf;  // parallel (a ray in the plane does not see it either)
    const double on = (double(p.point.x) - o.x) * p.normal.x + (double(p.point.y) - o.y) * p.normal.y +
                      (double(p.point.z) - o.z) * p.normal.z;
    const double t = on / dn;
    return t > double(tNear) && t < double(tFar) ? float(t) : kInf;
}

GeometrySet GeometrySet::load(const Scene& scene)
{
    GeometrySet set;
    for (size_t i = 0; i < scene.geometry.size(); ++i)
        set.addObject(scene, i);
    if (!set.mVertices.empty())
        set.mVertices.push_back(0.0f);  // Embree's 16-byte reads of the last vertex
    return set;
}

void GeometrySet::addObject(const Scene& scene, size_t index)
{
    const Geometry& g = scene.geometry[index];
    const std::string key =
        (scene.sourcePath.empty() ? std::string("scene") : scene.sourcePath) + ": geometry[" + std::to_string(index) + "]";
    if (!g.holdout && !g.shadows)
        logWarning(key + " ('" + g.name + "'): holdout and shadows are both false; the object changes nothing");
    if (!mVertices.empty() && mVertices.size() % 3 == 1)
        mVertices.pop_back();  // the padding goes at the very end

    GeometryObject obj;
    obj.name = g.name;
    obj.type = g.type;
    obj.holdout = g.holdout;
    obj.shadows = g.shadows;
    const uint32_t objectIndex = uint32_t(mObjects.size());
    auto addWorldTriangles = [&](const std::vector<float3>& objectPositions, const std::vector<uint32_t>& indices) {
        const uint64_t base = mVertices.size() / 3;
        if (base + objectPositions.size() > uint64_t(UINT32_MAX) ||
            mIndices.size() / 3 + indices.size() / 3 > uint64_t(UINT32_MAX))
            throw InputError(key + ": more than 2^32 vertices or triangles in the scene's geometry");
        obj.firstTriangle = uint32_t(mIndices.size() / 3);
        obj.triangleCount = uint32_t(indices.size() / 3);
        for (const float3& p : objectPositions) {
            const float3 w = g.transform.point(p);
            if (!isFinite(w))
                throw InputError(key + ".transform: places a vertex of '" + g.name + "' outside float range");
            mVertices.insert(mVertices.end(), {w.x, w.y, w.z});
            obj.bounds.expand(w);
        }
        for (uint32_t i : indices)
            mIndices.push_back(uint32_t(base) + i);
        obj.memoryBytes = objectPositions.size() * 3 * sizeof(float) + indices.size() * sizeof(uint32_t);
    };

    switch (g.type) {
    case GeometryType::Mesh: {
        const TriangleMesh mesh = readMeshFile(g.file, key + ".file");
        addWorldTriangles(mesh.positions, mesh.indices);
        break;
    }
    case GeometryType::Plane:
        if (g.bounded) {
            const float hx = 0.5f * g.size[0], hz = 0.5f * g.size[1];
            addWorldTriangles({make_float3(-hx, 0, -hz), make_float3(hx, 0, -hz), make_float3(hx, 0, hz),
                               make_float3(-hx, 0, hz)},
                              {0, 1, 2, 0, 2, 3});
        } else {
            InfinitePlane p;
            p.point = g.transform.point(make_float3(0, 0, 0));
            // Normals map by the inverse transpose: the plane's normal is row 1 of objectFromWorld.
            const Transform inv = g.transform.inverse();
            p.normal = normalize(make_float3(float(inv.at(1, 0)), float(inv.at(1, 1)), float(inv.at(1, 2))));
            p.object = objectIndex;
            obj.plane = int32_t(mPlanes.size());
            obj.memoryBytes = sizeof(InfinitePlane);
            mPlanes.push_back(p);
        }
        break;
    case GeometryType::Sphere: {
        SphereShape s;
        s.objectFromWorld = g.transform.inverse();
        s.radius = g.radius;
        s.object = objectIndex;
        Bbox local;
        local.expand(splat(-g.radius));
        local.expand(splat(g.radius));
        s.bounds = g.transform.box(local);
        obj.bounds = s.bounds;
        obj.sphere = int32_t(mSpheres.size());
        obj.memoryBytes = sizeof(SphereShape);
        mSpheres.push_back(s);
        break;
    }
    }
    mObjects.push_back(obj);
}

void GeometrySet::addTriangles(const std::string& name, const std::vector<float3>& positions,
                               const std::vector<uint32_t>& indices, bool holdout, bool shadows)
{
    if (!mVertices.empty() && mVertices.size() % 3 == 1)
        mVertices.pop_back();
    GeometryObject obj;
    obj.name = name;
    obj.holdout = holdout;
    obj.shadows = shadows;
    const uint32_t base = uint32_t(mVertices.size() / 3);
    obj.firstTriangle = uint32_t(mIndices.size() / 3);
    obj.triangleCount = uint32_t(indices.size() / 3);
    for (const float3& p : positions) {
        mVertices.insert(mVertices.end(), {p.x, p.y, p.z});
        obj.bounds.expand(p);
    }
    for (uint32_t i : indices)
        mIndices.push_back(base + i);
    obj.memoryBytes = positions.size() * 3 * sizeof(float) + indices.size() * sizeof(uint32_t);
    mObjects.push_back(obj);
    mVertices.push_back(0.0f);
}

size_t GeometrySet::memoryBytes() const
{
    return mVertices.size() * sizeof(float) + mIndices.size() * sizeof(uint32_t) +
           mSpheres.size() * sizeof(SphereShape) + mPlanes.size() * sizeof(InfinitePlane) +
           mObjects.size() * sizeof(GeometryObject);
}

}  // namespace nimbus
