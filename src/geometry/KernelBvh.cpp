#include "KernelBvh.h"

#include "../core/Error.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <string>

namespace nimbus {

// The layouts the kernel reads (kernels/shared/geometry.h), member by member.
static_assert(sizeof(NbBvhNode) == 32, "NbBvhNode layout is shared with OpenCL");
static_assert(offsetof(NbBvhNode, lo) == 0 && offsetof(NbBvhNode, offset) == 12 && offsetof(NbBvhNode, hi) == 16 &&
                  offsetof(NbBvhNode, count) == 28,
              "NbBvhNode member offsets are shared with OpenCL");
static_assert(sizeof(NbGeomPrim) == 64, "NbGeomPrim layout is shared with OpenCL");
static_assert(offsetof(NbGeomPrim, data) == 0 && offsetof(NbGeomPrim, radius) == 48 && offsetof(NbGeomPrim, type) == 52 &&
                  offsetof(NbGeomPrim, flags) == 56 && offsetof(NbGeomPrim, object) == 60,
              "NbGeomPrim member offsets are shared with OpenCL");
static_assert(sizeof(NbGeomScene) == 16, "NbGeomScene layout is shared with OpenCL");

namespace {

// The builder's tree, in memory from Embree's thread-local allocator (freed with the RTCBVH).
struct BuildNode {
    bool leaf = false;
};
struct BuildInner : BuildNode {
    BuildNode* child[2] = {nullptr, nullptr};
    RTCBounds bounds[2];
};
struct BuildLeaf : BuildNode {
    uint32_t count = 0;
    uint32_t* prims = nullptr;  // `count` entries, allocated right after the leaf
};

void* createNode(RTCThreadLocalAllocator alloc, unsigned int childCount, void*)
{
    (void)childCount;  // maxBranchingFactor 2
    void* mem = rtcThreadLocalAlloc(alloc, sizeof(BuildInner), 16);
    return new (mem) BuildInner();
}

void setChildren(void* node, void** children, unsigned int count, void*)
{
    auto* n = static_cast<BuildInner*>(node);
    for (unsigned i = 0; i < count && i < 2; ++i)
        n->child[i] = static_cast<BuildNode*>(children[i]);
}

void setBounds(void* node, const RTCBounds** bounds, unsigned int count, void*)
{
    auto* n = static_cast<BuildInner*>(node);
    for (unsigned i = 0; i < count && i < 2; ++i)
        n->bounds[i] = *bounds[i];
}

void* createLeaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count, void*)
{
    void* mem = rtcThreadLocalAlloc(alloc, sizeof(BuildLeaf) + count * sizeof(uint32_t), 16);
    auto* leaf = new (mem) BuildLeaf();
    leaf->leaf = true;
    leaf->count = uint32_t(count);
    leaf->prims = reinterpret_cast<uint32_t*>(leaf + 1);
    for (size_t i = 0; i < count; ++i)
        leaf->prims[i] = prims[i].primID;
    return leaf;
}

void setBox(NbBvhNode& n, const RTCBounds& b)
{
    n.lo[0] = b.lower_x, n.lo[1] = b.lower_y, n.lo[2] = b.lower_z;
    n.hi[0] = b.upper_x, n.hi[1] = b.upper_y, n.hi[2] = b.upper_z;
}

// Depth first: a node's first child follows it, its second child's index goes in `offset`.
struct Flattener {
    const std::vector<NbGeomPrim>& input;
    KernelBvh& out;
    void emit(const BuildNode* b, const RTCBounds& box, int depth)
    {
        out.depth = std::max(out.depth, depth);
        const size_t index = out.nodes.size();
        out.nodes.push_back(NbBvhNode{});
        setBox(out.nodes[index], box);
        if (b->leaf) {
            const auto* leaf = static_cast<const BuildLeaf*>(b);
            out.nodes[index].offset = nb_uint(out.prims.size());
            out.nodes[index].count = leaf->count;
            for (uint32_t i = 0; i < leaf->count; ++i)
                out.prims.push_back(input[leaf->prims[i]]);
            return;
        }
        const auto* inner = static_cast<const BuildInner*>(b);
        emit(inner->child[0], inner->bounds[0], depth + 1);
        out.nodes[index].offset = nb_uint(out.nodes.size());
        out.nodes[index].count = 0;
        emit(inner->child[1], inner->bounds[1], depth + 1);
    }
};

nb_uint flagsOf(const GeometryObject& o)
{
    return (o.holdout ? NB_GEOM_HOLDOUT : 0u) | (o.shadows ? NB_GEOM_SHADOWS : 0u);
}

}  // namespace

KernelBvh buildKernelBvh(const GeometrySet& geometry)
{
    const auto start = std::chrono::steady_clock::now();
    KernelBvh out;
    const auto& objects = geometry.objects();
    const auto& v = geometry.vertices();
    const auto& idx = geometry.indices();

    // The primitives in the set's order, and Embree's build records (primID = index here).
    std::vector<NbGeomPrim> input;
    std::vector<RTCBuildPrimitive> build;
    auto addBuild = [&](const Bbox& b) {
        RTCBuildPrimitive p;
        p.lower_x = b.lo.x, p.lower_y = b.lo.y, p.lower_z = b.lo.z;
        p.upper_x = b.hi.x, p.upper_y = b.hi.y, p.upper_z = b.hi.z;
        p.geomID = 0;
        p.primID = unsigned(build.size());
        build.push_back(p);
    };
    for (uint32_t oi = 0; oi < objects.size(); ++oi) {
        const GeometryObject& o = objects[oi];
        if (o.sphere >= 0) {
            const SphereShape& s = geometry.spheres()[size_t(o.sphere)];
            NbGeomPrim p{};
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 4; ++c)
                    p.data[4 * r + c] = float(s.objectFromWorld.at(r, c));
            p.radius = s.radius;
            p.type = NB_PRIM_SPHERE;
            p.flags = flagsOf(o);
            p.object = oi;
            input.push_back(p);
            addBuild(s.bounds);
        }
        for (uint32_t t = o.firstTriangle; t < o.firstTriangle + o.triangleCount; ++t) {
            NbGeomPrim p{};
            Bbox b;
            for (int k = 0; k < 3; ++k) {
                const size_t vi = idx[3 * size_t(t) + k];
                const float3 x = make_float3(v[3 * vi], v[3 * vi + 1], v[3 * vi + 2]);
                p.data[3 * k] = x.x, p.data[3 * k + 1] = x.y, p.data[3 * k + 2] = x.z;
                b.expand(x);
            }
            p.type = NB_PRIM_TRIANGLE;
            p.flags = flagsOf(o);
            p.object = oi;
            input.push_back(p);
            addBuild(b);
        }
    }

    if (!build.empty()) {
        struct Errors {
            std::string first;
        } errors;
        RTCDevice device = rtcNewDevice(nullptr);
        if (!device)
            throw Error("Embree: cannot create a device (error " + std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
        rtcSetDeviceErrorFunction(
            device,
            [](void* user, RTCError code, const char* message) {
                auto* e = static_cast<Errors*>(user);
                if (e->first.empty())
                    e->first = "Embree error " + std::to_string(int(code)) + ": " + (message ? message : "");
            },
            &errors);
        RTCBVH bvh = rtcNewBVH(device);
        RTCBuildArguments args = rtcDefaultBuildArguments();
        args.buildQuality = RTC_BUILD_QUALITY_MEDIUM;  // binned SAH (HIGH needs spatial splits)
        args.maxBranchingFactor = 2;
        args.maxDepth = NB_BVH_MAX_DEPTH;
        args.minLeafSize = 1;
        args.maxLeafSize = 4;
        args.traversalCost = 1.0f;
        args.intersectionCost = 1.0f;
        args.bvh = bvh;
        args.primitives = build.data();
        args.primitiveCount = build.size();
        args.primitiveArrayCapacity = build.size();
        args.createNode = createNode;
        args.setNodeChildren = setChildren;
        args.setNodeBounds = setBounds;
        args.createLeaf = createLeaf;
        // The records are rewritten by the builder: keep the scene's bounds for the root's box.
        Bbox all;
        for (const RTCBuildPrimitive& p : build) {
            all.expand(make_float3(p.lower_x, p.lower_y, p.lower_z));
            all.expand(make_float3(p.upper_x, p.upper_y, p.upper_z));
        }
        auto* root = static_cast<BuildNode*>(rtcBuildBVH(&args));
        if (root && errors.first.empty()) {
            RTCBounds rootBox;
            rootBox.lower_x = all.lo.x, rootBox.lower_y = all.lo.y, rootBox.lower_z = all.lo.z;
            rootBox.upper_x = all.hi.x, rootBox.upper_y = all.hi.y, rootBox.upper_z = all.hi.z;
            out.nodes.reserve(2 * build.size());
            out.prims.reserve(input.size() + geometry.infinitePlanes().size());
            Flattener{input, out}.emit(root, rootBox, 0);
        }
        rtcReleaseBVH(bvh);
        rtcReleaseDevice(device);
        if (!errors.first.empty() || !root)
            throw Error("building the path tracer's geometry BVH: " +
                        (errors.first.empty() ? std::string("Embree returned no tree") : errors.first));
        if (out.prims.size() != input.size())
            throw Error("building the path tracer's geometry BVH: the tree holds " + std::to_string(out.prims.size()) +
                        " of " + std::to_string(input.size()) + " primitives");
    }

    out.scene.nodeCount = int(out.nodes.size());
    out.scene.planeFirst = int(out.prims.size());
    for (const InfinitePlane& pl : geometry.infinitePlanes()) {
        NbGeomPrim p{};
        p.data[0] = pl.point.x, p.data[1] = pl.point.y, p.data[2] = pl.point.z;
        p.data[3] = pl.normal.x, p.data[4] = pl.normal.y, p.data[5] = pl.normal.z;
        p.type = NB_PRIM_PLANE;
        p.flags = flagsOf(objects[pl.object]);
        p.object = pl.object;
        out.prims.push_back(p);
    }
    out.scene.planeCount = int(out.prims.size()) - out.scene.planeFirst;
    out.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
}

}  // namespace nimbus
