// EmbreeScene against independent answers: a brute-force ray-triangle test over every triangle
// of a torus (10^4 triangles, 10^4 random rays: same hits, distances within float rounding), the
// analytic sphere and plane distances, the eight-ray packets against one ray at a time, and the
// holdout / shadow flags deciding which rays see which object.
#include "TorusMesh.h"

#include "../../kernels/shared/light.h"
#include "../../kernels/shared/rng.h"
#include "geometry/EmbreeScene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace nimbus;
using namespace nimbus::test;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Moller-Trumbore in double: the nearest t > 0 over every triangle, or INFINITY.
float bruteForce(const TriangleMesh& m, float3 o, float3 d)
{
    double best = kInf;
    for (size_t t = 0; t < m.triangleCount(); ++t) {
        const float3 a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                     c = m.positions[m.indices[3 * t + 2]];
        const double e1[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, e2[3] = {c.x - a.x, c.y - a.y, c.z - a.z};
        const double dd[3] = {d.x, d.y, d.z};
        const double p[3] = {dd[1] * e2[2] - dd[2] * e2[1], dd[2] * e2[0] - dd[0] * e2[2], dd[0] * e2[1] - dd[1] * e2[0]};
        const double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
        if (std::fabs(det) < 1e-300)
            continue;
        const double s[3] = {o.x - a.x, o.y - a.y, o.z - a.z};
        const double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
        if (u < 0 || u > 1)
            continue;
        const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
        const double v = (dd[0] * q[0] + dd[1] * q[1] + dd[2] * q[2]) / det;
        if (v < 0 || u + v > 1)
            continue;
        const double tt = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
        if (tt > 0 && tt < best)
            best = tt;
    }
    return float(best);
}

std::vector<float3> toVector(const TriangleMesh& m)
{
    return m.positions;
}

}  // namespace

TEST(EmbreeScene, TorusHitsMatchBruteForce)
{
    const TriangleMesh torus = torusMesh(1.0f, 0.3f, 100, 50);  // 10^4 triangles
    ASSERT_EQ(torus.triangleCount(), 10000u);
    GeometrySet set;
    set.addTriangles("torus", toVector(torus), torus.indices, true, true);
    const EmbreeScene scene(std::move(set));
    NbRng rng = nbRngStart(7, 0, 0);
    int hits = 0, disagreements = 0;
    constexpr int kRays = 10000;
    for (int i = 0; i < kRays; ++i) {
        // From points on a sphere of radius 3 toward points inside the torus's bounds.
        const float3 o = nbSampleSphereUniform(nbRngNext(&rng), nbRngNext(&rng)) * 3.0f;
        const float3 target = make_float3(2.6f * (nbRngNext(&rng) - 0.5f), 0.6f * (nbRngNext(&rng) - 0.5f),
                                          2.6f * (nbRngNext(&rng) - 0.5f));
        const float3 d = normalize(target - o);
        const float expected = bruteForce(torus, o, d);
        const float got = scene.holdoutHit(o, d);
        hits += expected < kInf;
        // A ray within rounding of an edge may be counted by one test and not the other; both
        // find a hit there within float rounding of the same distance, or none.
        const bool agree = (expected == kInf && got == kInf) ||
                           (expected < kInf && got < kInf && std::fabs(got - expected) <= 1e-5f * expected);
        disagreements += !agree;
        if (!agree && disagreements <= 5)
            ADD_FAILURE() << "ray " << i << ": brute force " << expected << ", Embree " << got;
    }
    EXPECT_GT(hits, kRays / 4);
    EXPECT_EQ(disagreements, 0);
}

TEST(EmbreeScene, EightRayPacketsEqualSingleRays)
{
    const TriangleMesh torus = torusMesh(1.0f, 0.3f, 60, 30);
    GeometrySet set;
    set.addTriangles("torus", toVector(torus), torus.indices, true, true);
    const EmbreeScene scene(std::move(set));
    NbRng rng = nbRngStart(9, 0, 0);
    constexpr int n = 61;  // not a multiple of eight: a part-filled last packet
    std::vector<float3> o(n), d(n);
    for (int i = 0; i < n; ++i) {
        o[i] = make_float3(0, 0.1f, 4);
        d[i] = normalize(make_float3(nbRngNext(&rng) - 0.5f, 0.3f * (nbRngNext(&rng) - 0.5f), -1.0f));
    }
    std::vector<float> t(n);
    scene.holdoutHits(n, o.data(), d.data(), t.data());
    int hits = 0;
    for (int i = 0; i < n; ++i) {
        EXPECT_EQ(t[i], scene.holdoutHit(o[i], d[i])) << "ray " << i;
        hits += t[i] < kInf;
    }
    EXPECT_GT(hits, 10);
}

TEST(EmbreeScene, SphereAndPlaneDistancesAreAnalytic)
{
    Scene s;
    Geometry ball;
    ball.type = GeometryType::Sphere;
    ball.radius = 0.5f;
    ball.transform = Transform::translate(0, 0, -3) * Transform::scale(2, 1, 1);  // an ellipsoid, x half-axis 1
    Geometry ground;
    ground.type = GeometryType::Plane;  // infinite: y = -2
    ground.transform = Transform::translate(0, -2, 0);
    s.geometry = {ball, ground};
    const EmbreeScene scene(GeometrySet::load(s));
    // Straight at the centre: the surface is 0.5 in front of it (z half-axis 0.5).
    EXPECT_NEAR(scene.holdoutHit(make_float3(0, 0, 0), make_float3(0, 0, -1)), 2.5f, 1e-6f);
    // Along x through the centre: the x half-axis is 1.
    EXPECT_NEAR(scene.holdoutHit(make_float3(-5, 0, -3), make_float3(1, 0, 0)), 4.0f, 1e-6f);
    // Starting inside: the far side.
    EXPECT_NEAR(scene.holdoutHit(make_float3(0, 0, -3), make_float3(0, 1, 0)), 0.5f, 1e-6f);
    // Down onto the infinite plane, far from the origin.
    const float3 down = normalize(make_float3(1, -1, 0));
    EXPECT_NEAR(scene.holdoutHit(make_float3(1000, 0, 50), down), 2.0f * std::sqrt(2.0f), 1e-4f);
    EXPECT_EQ(scene.holdoutHit(make_float3(0, 0, 0), make_float3(0, 1, 0)), kInf);
    EXPECT_TRUE(scene.occluded(make_float3(0, 0, 0), make_float3(0, -1, 0), 0.0f, kInf));
    EXPECT_FALSE(scene.occluded(make_float3(0, 0, 0), make_float3(0, -1, 0), 0.0f, 1.9f));
}

// holdout false: camera rays pass through; shadows false: light rays pass through.
TEST(EmbreeScene, FlagsChooseTheRays)
{
    const TriangleMesh quad{{make_float3(-1, -1, 0), make_float3(1, -1, 0), make_float3(1, 1, 0), make_float3(-1, 1, 0)},
                            {0, 1, 2, 0, 2, 3}};
    GeometrySet set;
    set.addTriangles("matte", quad.positions, quad.indices, true, false);
    std::vector<float3> behind = quad.positions;
    for (float3& p : behind)
        p.z = -1;
    set.addTriangles("caster", behind, quad.indices, false, true);
    const EmbreeScene scene(std::move(set));
    EXPECT_TRUE(scene.hasHoldouts());
    EXPECT_TRUE(scene.hasShadowCasters());
    const float3 o = make_float3(0, 0, 5), d = make_float3(0, 0, -1);
    EXPECT_NEAR(scene.holdoutHit(o, d), 5.0f, 1e-6f);         // the matte, not the caster
    EXPECT_NEAR(scene.shadowHit(o, d, 0.0f, kInf), 6.0f, 1e-6f);  // the caster, not the matte
    EXPECT_FALSE(scene.occluded(o, d, 0.0f, 5.5f));
    EXPECT_TRUE(scene.occluded(o, d, 0.0f, 6.5f));
    EXPECT_GT(scene.bvhBytes(), 0u);
}
