#include "core/Error.h"
#include "core/Transform.h"

#include <gtest/gtest.h>

using namespace nimbus;

TEST(Transform, InverseRoundTrips)
{
    Transform t = Transform::translate(1, 2, 3) * Transform::rotateDegrees(30, 1, 1, 0) * Transform::scale(2, 0.5, 4);
    Transform i = t.inverse();
    float3 p = make_float3(0.3f, -2.0f, 7.0f);
    float3 q = i.point(t.point(p));
    EXPECT_NEAR(q.x, p.x, 1e-5);
    EXPECT_NEAR(q.y, p.y, 1e-5);
    EXPECT_NEAR(q.z, p.z, 1e-5);
}

TEST(Transform, SingularThrows)
{
    EXPECT_TRUE(Transform::scale(1, 0, 1).isSingular());
    EXPECT_THROW(Transform::scale(1, 0, 1).inverse(), Error);
}

TEST(Bbox, SlabIntersection)
{
    Bbox b;
    b.expand(make_float3(-1, -1, -1));
    b.expand(make_float3(1, 1, 1));
    float t0, t1;
    float3 o = make_float3(-5, 0, 0), d = make_float3(1, 0, 0);
    ASSERT_TRUE(b.intersect(o, safeInverse(d), 0, 100, t0, t1));
    EXPECT_FLOAT_EQ(t0, 4);
    EXPECT_FLOAT_EQ(t1, 6);
    EXPECT_FALSE(b.intersect(make_float3(-5, 2, 0), safeInverse(d), 0, 100, t0, t1));
}
