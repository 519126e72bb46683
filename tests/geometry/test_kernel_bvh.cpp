// The path tracer's BVH (src/geometry/KernelBvh, kernels/shared/geometry.h) against Embree: 10^5
// random rays at a 12000-triangle torus, closest hits (Embree's rtcIntersect1 through
// EmbreeScene::holdoutHit) and any hits over a finite segment (rtcOccluded1), through the host
// build of the traversal and through the same code compiled for the OpenCL device; the flattened
// tree's invariants; the shared structs' layout as the device compiler sees it; spheres and
// infinite planes against the host's analytic distances; the flags choosing which rays see what.
#include "../TestDir.h"
#include "TorusMesh.h"

#include "../../kernels/shared/light.h"
#include "../../kernels/shared/rng.h"
#include "geometry/EmbreeScene.h"
#include "geometry/KernelBvh.h"
#include "pathtracer/KernelCache.h"
#include "pathtracer/OpenCl.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>

using namespace nimbus;
using namespace nimbus::test;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Rays {
    std::vector<float3> o, d;
};

// From points on a sphere of radius 3 toward points in the torus's bounds (most rays hit, many
// graze), as EmbreeScene.TorusHitsMatchBruteForce.
Rays randomRays(int n, nb_uint seed)
{
    Rays r;
    NbRng rng = nbRngStart(seed, 0, 0);
    for (int i = 0; i < n; ++i) {
        const float3 o = nbSampleSphereUniform(nbRngNext(&rng), nbRngNext(&rng)) * 3.0f;
        const float3 target = make_float3(2.6f * (nbRngNext(&rng) - 0.5f), 0.6f * (nbRngNext(&rng) - 0.5f),
                                          2.6f * (nbRngNext(&rng) - 0.5f));
        r.o.push_back(o);
        r.d.push_back(normalize(target - o));
    }
    return r;
}

float traceHost(const KernelBvh& bvh, float3 o, float3 d, float tNear, float tFar, nb_uint flag, int anyHit)
{
    return nbGeomTrace(bvh.nodes.data(), bvh.prims.data(), bvh.scene, o, d, tNear, tFar, flag, anyHit);
}

// Two float computations of one hit distance (Woop's shear here, Embree's robust Pluecker test
// there) differ by a few ulps of t; a ray through a shared edge may pick either triangle, at
// the same distance to rounding. 1e-5 relative is ~80 ulps: far below any gap between surfaces.
bool sameHit(float a, float b)
{
    return (a == kInf && b == kInf) || (a < kInf && b < kInf && std::fabs(a - b) <= 1e-5f * std::max(a, b));
}

// The exact nearest hit over every triangle in double (Moller-Trumbore), and |cos| between the
// ray and that triangle's normal.
double exactHit(const std::vector<NbGeomPrim>& prims, float3 o, float3 d, double* cosine)
{
    double best = kInf;
    *cosine = 1.0;
    for (const NbGeomPrim& p : prims) {
        double a[3], e1[3], e2[3], s[3];
        const double dd[3] = {d.x, d.y, d.z}, oo[3] = {o.x, o.y, o.z};
        for (int k = 0; k < 3; ++k) {
            a[k] = p.data[k];
            e1[k] = double(p.data[3 + k]) - a[k];
            e2[k] = double(p.data[6 + k]) - a[k];
            s[k] = oo[k] - a[k];
        }
        const double pv[3] = {dd[1] * e2[2] - dd[2] * e2[1], dd[2] * e2[0] - dd[0] * e2[2], dd[0] * e2[1] - dd[1] * e2[0]};
        const double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
        if (det == 0.0)
            continue;
        const double u = (s[0] * pv[0] + s[1] * pv[1] + s[2] * pv[2]) / det;
        const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
        const double v = (dd[0] * q[0] + dd[1] * q[1] + dd[2] * q[2]) / det;
        const double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
        if (u < 0 || v < 0 || u + v > 1 || !(t > 0) || t >= best)
            continue;
        best = t;
        const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        *cosine = std::fabs(det) / std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    }
    return best;
}

// Where the two differ by more than sameHit allows: whether the ray is ill-conditioned and both
// answers are within float rounding of the exact one. At incidence cosine c a float hit
// distance is off by about eps (t + |o - v|) / c (the plane's offset, rounded, moved along a
// ray at grazing incidence), so both must be within 16 eps (t + 3) / c of the exact t.
bool bothWithinRounding(const std::vector<NbGeomPrim>& prims, float3 o, float3 d, float a, float b)
{
    double c = 1.0;
    const double t = exactHit(prims, o, d, &c);
    if (!(t < kInf) || !(a < kInf) || !(b < kInf))
        return false;
    const double bound = 16.0 * 0x1p-24 * (t + 3.0) / c;
    return std::fabs(a - t) <= bound && std::fabs(b - t) <= bound;
}

// The torus as the geometry tests use it: 2 x 120 x 50 = 12000 triangles.
GeometrySet torusSet(bool holdout, bool shadows)
{
    const TriangleMesh torus = torusMesh(1.0f, 0.3f, 120, 50);
    GeometrySet set;
    set.addTriangles("torus", torus.positions, torus.indices, holdout, shadows);
    return set;
}

constexpr int kRays = 100000;
constexpr float kShadowSegment = 2.5f;  // any-hit rays: (0, 2.5) of each ray, the torus's front half

struct EmbreeAnswers {
    std::vector<float> closest;
    std::vector<int> occluded;
};

EmbreeAnswers askEmbree(const EmbreeScene& scene, const Rays& r)
{
    EmbreeAnswers a;
    for (size_t i = 0; i < r.o.size(); ++i) {
        a.closest.push_back(scene.holdoutHit(r.o[i], r.d[i]));
        a.occluded.push_back(scene.occluded(r.o[i], r.d[i], 0.0f, kShadowSegment) ? 1 : 0);
    }
    return a;
}

void expectAgreement(const char* who, const KernelBvh& bvh, const Rays& r, const EmbreeAnswers& embree,
                     const std::vector<float>& closest, const std::vector<int>& occluded)
{
    int hits = 0, occludedCount = 0, closestOff = 0, anyOff = 0, grazing = 0;
    for (size_t i = 0; i < closest.size(); ++i) {
        hits += embree.closest[i] < kInf;
        occludedCount += embree.occluded[i];
        if (sameHit(closest[i], embree.closest[i]))
            continue;
        if (bothWithinRounding(bvh.prims, r.o[i], r.d[i], closest[i], embree.closest[i])) {
            ++grazing;
            continue;
        }
        if (++closestOff <= 5)
            ADD_FAILURE() << who << " ray " << i << ": Embree " << embree.closest[i] << ", kernel BVH " << closest[i];
        if (occluded[i] != embree.occluded[i] && ++anyOff <= 5)
            ADD_FAILURE() << who << " shadow ray " << i << ": Embree " << embree.occluded[i] << ", kernel BVH "
                          << occluded[i];
    }
    EXPECT_EQ(closestOff, 0) << who << ": closest hits that differ of " << closest.size();
    // Grazing rays where both are within rounding of the exact distance but not of each other:
    // a handful in 10^5, or the traversal is imprecise in general.
    EXPECT_LE(grazing, 10) << who;
    std::printf("%s: %d of %zu rays hit, %d grazing hits agree only through the exact distance\n", who, hits,
                closest.size(), grazing);
    EXPECT_EQ(anyOff, 0) << who << ": any-hit answers that differ";
    EXPECT_GT(hits, kRays / 4);
    EXPECT_GT(occludedCount, kRays / 8);
    EXPECT_LT(occludedCount, hits);  // the segment is short enough that some hits lie beyond it
}

}  // namespace

TEST(KernelBvh, TreeHoldsEveryPrimitiveOnceInsideItsBoxes)
{
    const GeometrySet set = torusSet(true, true);
    const KernelBvh bvh = buildKernelBvh(set);
    ASSERT_GT(bvh.nodes.size(), 1u);
    EXPECT_EQ(bvh.prims.size(), 12000u);
    EXPECT_EQ(bvh.scene.nodeCount, int(bvh.nodes.size()));
    EXPECT_EQ(bvh.scene.planeFirst, 12000);
    EXPECT_EQ(bvh.scene.planeCount, 0);
    EXPECT_LE(bvh.depth, NB_BVH_MAX_DEPTH);
    // Walk the tree: children inside their parent's range, leaves covering [0, prims) exactly
    // once, every vertex of a leaf's triangles inside every box on its way from the root.
    std::vector<int> seen(bvh.prims.size(), 0);
    struct Item {
        uint32_t node;
        int depth;
    };
    std::vector<Item> stack = {{0, 0}};
    size_t leaves = 0;
    auto inside = [&](const NbBvhNode& n, float x, float y, float z) {
        return x >= n.lo[0] && x <= n.hi[0] && y >= n.lo[1] && y <= n.hi[1] && z >= n.lo[2] && z <= n.hi[2];
    };
    std::vector<std::vector<uint32_t>> ancestors(bvh.nodes.size());
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        ASSERT_LT(it.node, bvh.nodes.size());
        const NbBvhNode& n = bvh.nodes[it.node];
        std::vector<uint32_t> up = ancestors[it.node];
        up.push_back(it.node);
        if (n.count > 0) {
            ++leaves;
            EXPECT_LE(n.count, 4u);
            for (uint32_t k = 0; k < n.count; ++k) {
                ASSERT_LT(n.offset + k, bvh.prims.size());
                ++seen[n.offset + k];
                const NbGeomPrim& p = bvh.prims[n.offset + k];
                EXPECT_EQ(p.type, NB_PRIM_TRIANGLE);
                EXPECT_EQ(p.flags, NB_GEOM_HOLDOUT | NB_GEOM_SHADOWS);
                for (uint32_t a : up)
                    for (int v = 0; v < 3; ++v)
                        EXPECT_TRUE(inside(bvh.nodes[a], p.data[3 * v], p.data[3 * v + 1], p.data[3 * v + 2]))
                            << "prim " << n.offset + k << " outside node " << a;
            }
            continue;
        }
        EXPECT_GT(n.offset, it.node + 1) << "the second child follows the first's subtree";
        ASSERT_LT(n.offset, bvh.nodes.size());
        ancestors[it.node + 1] = up;
        ancestors[n.offset] = up;
        stack.push_back({it.node + 1, it.depth + 1});
        stack.push_back({n.offset, it.depth + 1});
    }
    for (size_t i = 0; i < seen.size(); ++i)
        ASSERT_EQ(seen[i], 1) << "prim " << i;
    EXPECT_EQ(bvh.nodes.size(), 2 * leaves - 1);  // a binary tree
}

TEST(KernelBvh, HostTraversalAgreesWithEmbreeOn100kRays)
{
    const KernelBvh bvh = buildKernelBvh(torusSet(true, true));
    const EmbreeScene embree(torusSet(true, true));
    const Rays r = randomRays(kRays, 11);
    const EmbreeAnswers e = askEmbree(embree, r);
    std::vector<float> closest;
    std::vector<int> occluded;
    for (int i = 0; i < kRays; ++i) {
        closest.push_back(traceHost(bvh, r.o[i], r.d[i], 0.0f, kInf, NB_GEOM_HOLDOUT, 0));
        occluded.push_back(traceHost(bvh, r.o[i], r.d[i], 0.0f, kShadowSegment, NB_GEOM_SHADOWS, 1) < kInf);
    }
    expectAgreement("host", bvh, r, e, closest, occluded);
}

namespace {

const std::string kTestKernel = std::string(NIMBUS_TEST_DIR) + "/bvh_trace.cl";

void useTestKernelCache()
{
    const std::string dir = std::string(::testing::TempDir()) + "nimbus-kernel-cache-bvh";
    setenv("NIMBUS_CACHE_DIR", dir.c_str(), 1);
}

}  // namespace

TEST(KernelBvh, DeviceTraversalAgreesWithEmbreeOn100kRays)
{
    useTestKernelCache();
    const KernelBvh bvh = buildKernelBvh(torusSet(true, true));
    const EmbreeScene embree(torusSet(true, true));
    const Rays r = randomRays(kRays, 13);
    const EmbreeAnswers e = askEmbree(embree, r);

    ocl::Context cl(ocl::selectDevice(""));
    ProgramBuild build = buildProgram(cl, kTestKernel, "");
    cl_int err = CL_SUCCESS;
    ocl::Kernel k(clCreateKernel(build.program.get(), "traceRays", &err));
    ocl::check(err, "clCreateKernel(traceRays)");
    std::vector<float> rays;
    for (int i = 0; i < kRays; ++i)
        rays.insert(rays.end(), {r.o[i].x, r.o[i].y, r.o[i].z, r.d[i].x, r.d[i].y, r.d[i].z});
    ocl::Mem nodes = cl.upload(bvh.nodes), prims = cl.upload(bvh.prims), rayBuf = cl.upload(rays);
    ocl::Mem closestBuf = cl.allocate(kRays * sizeof(float)), occludedBuf = cl.allocate(kRays * sizeof(cl_int));
    const cl_mem n = nodes.get(), p = prims.get(), rb = rayBuf.get(), cb = closestBuf.get(), ob = occludedBuf.get();
    const float tShadow = kShadowSegment;
    const int count = kRays;
    ocl::check(clSetKernelArg(k.get(), 0, sizeof(cl_mem), &n), "arg");
    ocl::check(clSetKernelArg(k.get(), 1, sizeof(cl_mem), &p), "arg");
    ocl::check(clSetKernelArg(k.get(), 2, sizeof bvh.scene, &bvh.scene), "arg");
    ocl::check(clSetKernelArg(k.get(), 3, sizeof(cl_mem), &rb), "arg");
    ocl::check(clSetKernelArg(k.get(), 4, sizeof(float), &tShadow), "arg");
    ocl::check(clSetKernelArg(k.get(), 5, sizeof(int), &count), "arg");
    ocl::check(clSetKernelArg(k.get(), 6, sizeof(cl_mem), &cb), "arg");
    ocl::check(clSetKernelArg(k.get(), 7, sizeof(cl_mem), &ob), "arg");
    const size_t global = kRays;
    ocl::check(clEnqueueNDRangeKernel(cl.queue(), k.get(), 1, nullptr, &global, nullptr, 0, nullptr, nullptr),
               "launch");
    std::vector<float> closest(kRays);
    std::vector<int> occluded(kRays);
    cl.read(closestBuf, closest.data(), closest.size() * sizeof(float));
    cl.read(occludedBuf, occluded.data(), occluded.size() * sizeof(int));
    expectAgreement("device", bvh, r, e, closest, occluded);
}

// The device compiler reads every field where the host wrote it (NbBvhNode, NbGeomPrim,
// NbGeomScene; index 1 of each array, so the stride is sizeof as well).
TEST(KernelBvh, DeviceLayoutMatchesHost)
{
    useTestKernelCache();
    std::vector<NbBvhNode> nodes(2);
    nodes[1] = NbBvhNode{{1.5f, 2.5f, 3.5f}, 4u, {5.5f, 6.5f, 7.5f}, 8u};
    std::vector<NbGeomPrim> prims(2);
    for (int k = 0; k < 12; ++k)
        prims[1].data[k] = 10.0f + float(k);
    prims[1].radius = 30.0f, prims[1].type = 31u, prims[1].flags = 32u, prims[1].object = 33u;
    const NbGeomScene g{40, 41, 42, 43};
    ocl::Context cl(ocl::selectDevice(""));
    ProgramBuild build = buildProgram(cl, kTestKernel, "");
    cl_int err = CL_SUCCESS;
    ocl::Kernel k(clCreateKernel(build.program.get(), "readLayout", &err));
    ocl::check(err, "clCreateKernel(readLayout)");
    ocl::Mem nb = cl.upload(nodes), pb = cl.upload(prims), out = cl.allocate(31 * sizeof(float));
    const cl_mem a0 = nb.get(), a1 = pb.get(), a3 = out.get();
    ocl::check(clSetKernelArg(k.get(), 0, sizeof(cl_mem), &a0), "arg");
    ocl::check(clSetKernelArg(k.get(), 1, sizeof(cl_mem), &a1), "arg");
    ocl::check(clSetKernelArg(k.get(), 2, sizeof g, &g), "arg");
    ocl::check(clSetKernelArg(k.get(), 3, sizeof(cl_mem), &a3), "arg");
    const size_t one = 1;
    ocl::check(clEnqueueNDRangeKernel(cl.queue(), k.get(), 1, nullptr, &one, nullptr, 0, nullptr, nullptr), "launch");
    std::vector<float> v(31);
    cl.read(out, v.data(), v.size() * sizeof(float));
    const float expected[31] = {1.5f, 2.5f, 3.5f, 4,  5.5f, 6.5f, 7.5f, 8,  10, 11, 12, 13, 14, 15,     16, 17,
                                18,   19,   20,   21, 30,   31,   32,   33, 40, 41, 42, 43, 32, 64,     16};
    for (int i = 0; i < 31; ++i)
        EXPECT_EQ(v[i], expected[i]) << "field " << i;
}

// Spheres (under a non-uniform scale) and infinite planes: the kernel's float quadric against
// the host's double one, and the flags: holdout rays see only holdouts, shadow rays only casters.
TEST(KernelBvh, SpheresPlanesAndFlags)
{
    Scene scene;
    Geometry ball;
    ball.name = "ball";
    ball.type = GeometryType::Sphere;
    ball.radius = 0.5f;
    ball.transform = Transform::translate(0.2, 0.1, -1.0) * Transform::scale(1.0, 2.0, 0.5);
    ball.holdout = true, ball.shadows = false;
    Geometry floor;
    floor.name = "floor";
    floor.type = GeometryType::Plane;
    floor.transform = Transform::translate(0, -1.5, 0);
    floor.holdout = false, floor.shadows = true;
    scene.geometry = {ball, floor};
    const GeometrySet set = GeometrySet::load(scene);
    const KernelBvh bvh = buildKernelBvh(set);
    ASSERT_EQ(bvh.scene.planeCount, 1);
    ASSERT_EQ(bvh.prims.size(), 2u);
    const SphereShape& s = set.spheres()[0];
    const InfinitePlane& pl = set.infinitePlanes()[0];
    NbRng rng = nbRngStart(5, 0, 0);
    int sphereHits = 0, planeHits = 0;
    for (int i = 0; i < 20000; ++i) {
        const float3 o = make_float3(0.0f, 0.5f, 3.0f);
        const float3 d = normalize(make_float3(0.6f * (nbRngNext(&rng) - 0.5f), 1.5f * (0.3f - nbRngNext(&rng)), -1.0f));
        const float ts = intersectSphere(s, o, d, 0.0f, kInf), tp = intersectPlane(pl, o, d, 0.0f, kInf);
        const float holdout = traceHost(bvh, o, d, 0.0f, kInf, NB_GEOM_HOLDOUT, 0);
        const float shadow = traceHost(bvh, o, d, 0.0f, kInf, NB_GEOM_SHADOWS, 0);
        EXPECT_TRUE(sameHit(holdout, ts)) << i << ": sphere " << ts << ", kernel " << holdout;
        EXPECT_TRUE(sameHit(shadow, tp)) << i << ": plane " << tp << ", kernel " << shadow;
        EXPECT_EQ(traceHost(bvh, o, d, 0.0f, kInf, NB_GEOM_SHADOWS, 1) < kInf, tp < kInf);
        sphereHits += ts < kInf, planeHits += tp < kInf;
    }
    EXPECT_GT(sphereHits, 1000);
    EXPECT_GT(planeHits, 1000);
    EXPECT_LT(planeHits, 19000);
}
