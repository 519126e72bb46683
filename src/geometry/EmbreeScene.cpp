#include "EmbreeScene.h"

#include "../core/Error.h"

#include <embree3/rtcore.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

namespace nimbus {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Embree reports errors through a callback; the first one of a build is kept and thrown.
struct DeviceErrors {
    std::string first;
};

void onEmbreeError(void* user, RTCError code, const char* message)
{
    auto* errors = static_cast<DeviceErrors*>(user);
    if (errors->first.empty())
        errors->first = "Embree error " + std::to_string(int(code)) + ": " + (message ? message : "");
}

bool onEmbreeMemory(void* user, ssize_t bytes, bool /*post*/)
{
    static_cast<std::atomic<int64_t>*>(user)->fetch_add(int64_t(bytes), std::memory_order_relaxed);
    return true;
}

// ---- spheres as user geometry: the exact quadric (GeometrySet.h) ---------------------------

void sphereBounds(const RTCBoundsFunctionArguments* args)
{
    const SphereShape& s = *static_cast<const SphereShape*>(args->geometryUserPtr);
    RTCBounds* b = args->bounds_o;
    b->lower_x = s.bounds.lo.x, b->lower_y = s.bounds.lo.y, b->lower_z = s.bounds.lo.z;
    b->upper_x = s.bounds.hi.x, b->upper_y = s.bounds.hi.y, b->upper_z = s.bounds.hi.z;
}

void sphereIntersect(const RTCIntersectFunctionNArguments* args)
{
    const SphereShape& s = *static_cast<const SphereShape*>(args->geometryUserPtr);
    RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, args->N);
    RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, args->N);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1)
            continue;
        const float3 o = make_float3(RTCRayN_org_x(ray, args->N, i), RTCRayN_org_y(ray, args->N, i),
                                     RTCRayN_org_z(ray, args->N, i));
        const float3 d = make_float3(RTCRayN_dir_x(ray, args->N, i), RTCRayN_dir_y(ray, args->N, i),
                                     RTCRayN_dir_z(ray, args->N, i));
        float& tfar = RTCRayN_tfar(ray, args->N, i);
        const float t = intersectSphere(s, o, d, RTCRayN_tnear(ray, args->N, i), tfar);
        if (!(t < tfar))
            continue;
        tfar = t;
        RTCHitN_u(hit, args->N, i) = 0.0f;
        RTCHitN_v(hit, args->N, i) = 0.0f;
        RTCHitN_Ng_x(hit, args->N, i) = 0.0f;  // unshaded: no normal is read
        RTCHitN_Ng_y(hit, args->N, i) = 0.0f;
        RTCHitN_Ng_z(hit, args->N, i) = 1.0f;
        RTCHitN_primID(hit, args->N, i) = args->primID;
        RTCHitN_geomID(hit, args->N, i) = args->geomID;
        RTCHitN_instID(hit, args->N, i, 0) = args->context->instID[0];
    }
}

void sphereOccluded(const RTCOccludedFunctionNArguments* args)
{
    const SphereShape& s = *static_cast<const SphereShape*>(args->geometryUserPtr);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1)
            continue;
        RTCRayN* ray = args->ray;
        const float3 o = make_float3(RTCRayN_org_x(ray, args->N, i), RTCRayN_org_y(ray, args->N, i),
                                     RTCRayN_org_z(ray, args->N, i));
        const float3 d = make_float3(RTCRayN_dir_x(ray, args->N, i), RTCRayN_dir_y(ray, args->N, i),
                                     RTCRayN_dir_z(ray, args->N, i));
        float& tfar = RTCRayN_tfar(ray, args->N, i);
        if (intersectSphere(s, o, d, RTCRayN_tnear(ray, args->N, i), tfar) < tfar)
            tfar = -kInf;  // Embree's mark of an occluded ray
    }
}

RTCRay makeRay(float3 o, float3 d, float tNear, float tFar)
{
    RTCRay r;
    r.org_x = o.x, r.org_y = o.y, r.org_z = o.z;
    r.dir_x = d.x, r.dir_y = d.y, r.dir_z = d.z;
    r.tnear = tNear, r.tfar = tFar;
    r.time = 0.0f;
    r.mask = ~0u;
    r.id = 0;
    r.flags = 0;
    return r;
}

}  // namespace

struct EmbreeScene::Impl {
    DeviceErrors errors;
    std::atomic<int64_t> bytes{0};
    RTCDevice device = nullptr;
};

EmbreeScene::EmbreeScene(GeometrySet geometry) : mGeometry(std::move(geometry)), mImpl(std::make_unique<Impl>())
{
    const auto start = std::chrono::steady_clock::now();
    Impl& im = *mImpl;
    im.device = rtcNewDevice(nullptr);
    if (!im.device)
        throw Error("Embree: cannot create a device (error " + std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
    rtcSetDeviceErrorFunction(im.device, onEmbreeError, &im.errors);
    rtcSetDeviceMemoryMonitorFunction(im.device, onEmbreeMemory, &im.bytes);

    const auto& objects = mGeometry.objects();
    auto objectsIn = [&](bool holdoutSet) {
        std::vector<uint32_t> list;
        for (uint32_t i = 0; i < objects.size(); ++i)
            if (holdoutSet ? objects[i].holdout : objects[i].shadows)
                list.push_back(i);
        return list;
    };
    // One Embree scene of the listed objects; their infinite planes go to the set's list.
    auto buildSet = [&](const std::vector<uint32_t>& list, RaySet& set) {
        set.any = !list.empty();
        RTCScene scene = nullptr;
        for (uint32_t i : list) {
            const GeometryObject& obj = objects[i];
            if (obj.plane >= 0) {
                set.planes.push_back(uint32_t(obj.plane));
                continue;
            }
            RTCGeometry g = nullptr;
            if (obj.sphere >= 0) {
                g = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_USER);
                rtcSetGeometryUserPrimitiveCount(g, 1);
                rtcSetGeometryUserData(g, const_cast<SphereShape*>(&mGeometry.spheres()[size_t(obj.sphere)]));
                rtcSetGeometryBoundsFunction(g, sphereBounds, nullptr);
                rtcSetGeometryIntersectFunction(g, sphereIntersect);
                rtcSetGeometryOccludedFunction(g, sphereOccluded);
            } else if (obj.triangleCount > 0) {
                g = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_TRIANGLE);
                rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, mGeometry.vertices().data(),
                                           0, 3 * sizeof(float), mGeometry.vertexCount());
                rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, mGeometry.indices().data(),
                                           size_t(obj.firstTriangle) * 3 * sizeof(uint32_t), 3 * sizeof(uint32_t),
                                           obj.triangleCount);
            }
            if (!g)
                continue;
            rtcCommitGeometry(g);
            if (!scene) {
                scene = rtcNewScene(im.device);
                // Robust: no ray slips between two triangles that share an edge (a pixel of
                // background through a holdout), at a small cost in traversal.
                rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
                rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
            }
            rtcAttachGeometryByID(scene, g, i);  // geomID = object index
            rtcReleaseGeometry(g);
        }
        if (scene)
            rtcCommitScene(scene);
        set.scene = scene;
    };
    const std::vector<uint32_t> holdouts = objectsIn(true), shadows = objectsIn(false);
    buildSet(holdouts, mHoldouts);
    if (shadows == holdouts) {
        mShadows = mHoldouts;  // the same scene serves both (released once)
    } else {
        buildSet(shadows, mShadows);
    }
    if (!im.errors.first.empty())
        throw Error("building the geometry's BVH: " + im.errors.first);
    mBuildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

EmbreeScene::~EmbreeScene()
{
    if (mShadows.scene && mShadows.scene != mHoldouts.scene)
        rtcReleaseScene(static_cast<RTCScene>(mShadows.scene));
    if (mHoldouts.scene)
        rtcReleaseScene(static_cast<RTCScene>(mHoldouts.scene));
    if (mImpl && mImpl->device)
        rtcReleaseDevice(mImpl->device);
}

size_t EmbreeScene::bvhBytes() const
{
    return size_t(std::max<int64_t>(0, mImpl->bytes.load()));
}

float EmbreeScene::firstHit(const RaySet& set, float3 o, float3 d, float tNear, float tFar) const
{
    float t = kInf;
    if (set.scene) {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRayHit rh;
        rh.ray = makeRay(o, d, tNear, tFar);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(static_cast<RTCScene>(set.scene), &context, &rh);
        if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID)
            t = rh.ray.tfar;
    }
    for (uint32_t p : set.planes)
        t = std::min(t, intersectPlane(mGeometry.infinitePlanes()[p], o, d, tNear, std::min(t, tFar)));
    return t;
}

float EmbreeScene::holdoutHit(float3 o, float3 d, float tFar) const
{
    return firstHit(mHoldouts, o, d, 0.0f, tFar);
}

void EmbreeScene::holdoutHits(int n, const float3* o, const float3* d, float* t) const
{
    if (!mHoldouts.scene) {
        for (int i = 0; i < n; ++i)
            t[i] = firstHit(mHoldouts, o[i], d[i], 0.0f, kInf);
        return;
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;  // a tile row: neighbouring pixels' rays
    for (int first = 0; first < n; first += 8) {
        const int m = std::min(8, n - first);
        alignas(32) int valid[8];
        alignas(32) RTCRayHit8 rh;
        for (int i = 0; i < 8; ++i) {
            const int k = first + std::min(i, m - 1);  // idle lanes repeat the last ray, masked off
            valid[i] = i < m ? -1 : 0;
            rh.ray.org_x[i] = o[k].x, rh.ray.org_y[i] = o[k].y, rh.ray.org_z[i] = o[k].z;
            rh.ray.dir_x[i] = d[k].x, rh.ray.dir_y[i] = d[k].y, rh.ray.dir_z[i] = d[k].z;
            rh.ray.tnear[i] = 0.0f, rh.ray.tfar[i] = kInf;
            rh.ray.time[i] = 0.0f, rh.ray.mask[i] = ~0u, rh.ray.id[i] = unsigned(i), rh.ray.flags[i] = 0;
            rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect8(valid, static_cast<RTCScene>(mHoldouts.scene), &context, &rh);
        for (int i = 0; i < m; ++i) {
            float ti = rh.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID ? rh.ray.tfar[i] : kInf;
            for (uint32_t p : mHoldouts.planes)
                ti = std::min(ti, intersectPlane(mGeometry.infinitePlanes()[p], o[first + i], d[first + i], 0.0f, ti));
            t[first + i] = ti;
        }
    }
}

float EmbreeScene::shadowHit(float3 o, float3 d, float tNear, float tFar) const
{
    return firstHit(mShadows, o, d, tNear, tFar);
}

bool EmbreeScene::occluded(float3 o, float3 d, float tNear, float tFar) const
{
    for (uint32_t p : mShadows.planes)
        if (intersectPlane(mGeometry.infinitePlanes()[p], o, d, tNear, tFar) < kInf)
            return true;
    if (!mShadows.scene)
        return false;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay ray = makeRay(o, d, tNear, tFar);
    rtcOccluded1(static_cast<RTCScene>(mShadows.scene), &context, &ray);
    return ray.tfar < 0.0f;
}

}  // namespace nimbus
