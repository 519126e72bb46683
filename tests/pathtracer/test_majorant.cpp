// The majorant walk (kernels/shared/majorant.h), compiled for the host: along random rays
// through overlapping, rotated, partly empty volumes, the stretches it returns are ordered and
// disjoint, and wherever the medium has extinction the point lies in a stretch whose majorant
// bounds it (checked against VolumeSet::sample, the host integrators' independent lookup).
#include "PtWorld.h"

#include "../../kernels/shared/majorant.h"
#include "pathtracer/PathtraceScene.h"

#include <gtest/gtest.h>

#include <random>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

void rotate(VolumeData& v, double degrees, double ax, double ay, double az)
{
    v.worldFromIndex = Transform::rotateDegrees(degrees, ax, ay, az) * v.worldFromIndex;
    v.indexFromWorld = v.worldFromIndex.inverse();
    v.worldBounds = v.worldFromIndex.box(v.density.activeIndexBounds());
}

struct Stretch {
    float t0, t1, maj;
};

}  // namespace

TEST(MajorantWalk, StretchesBoundExtinctionAlongRandomRays)
{
    World w(4, 4);
    // A cloud with holes (zero bricks) and a rotated, anisotropically scaled second volume.
    auto a = boxVolume(make_float3(-1, -1, -1), make_float3(1, 1, 1), {3, 3, 3},
                       medium(make_float3(1, 2, 3), splat(0.5f)), [](float3 u) {
                           float r = length(u - splat(0.5f));
                           return r < 0.45f ? (0.5f + std::sin(9 * u.x) * std::cos(7 * u.y)) * (r > 0.2f) : 0.0f;
                       });
    auto b = boxVolume(make_float3(-0.3f, -1.5f, -0.2f), make_float3(0.9f, 0.5f, 0.4f), {2, 1, 1},
                       medium(splat(4.0f), splat(0.0f)), [](float3 u) { return std::max(0.0f, u.x - u.y); });
    rotate(*b, 30, 0.2, 1, 0.3);
    w.volumes = {a, b};
    const RenderContext& ctx = w.context();
    PathtraceScene ps = buildPathtraceScene(ctx);
    ASSERT_EQ(ps.volumes.size(), 2u);

    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(-1, 1);
    int checkedInside = 0, rays = 0;
    for (int r = 0; r < 400; ++r) {
        float3 o = make_float3(3 * u(rng), 3 * u(rng), 3 * u(rng));
        if (r % 4 == 0)
            o = o * 0.2f;  // some origins inside the volumes
        float3 target = make_float3(0.8f * u(rng), 0.8f * u(rng), 0.8f * u(rng));
        float3 d = normalize(target - o);
        if (r % 10 == 0)
            d = make_float3(0, 0, r % 20 == 0 ? 1.0f : -1.0f);  // axis-aligned: zero components
        NbMajorantIter it;
        nbMajorantInit(&it, ps.volumes.data(), int(ps.volumes.size()), o, d, 0.0f, NB_INF, 0.0f, ps.majorants.data());
        std::vector<Stretch> stretches;
        float segEnd = 0, maj = 0;
        while (nbMajorantNext(&it, ps.volumes.data(), ps.majorants.data(), &segEnd, &maj)) {
            ASSERT_GE(segEnd, it.t);
            ASSERT_GT(maj, 0.0f);
            if (!stretches.empty()) {
                ASSERT_GE(it.t, stretches.back().t1);
            }
            stretches.push_back({it.t, segEnd, maj});
            it.t = segEnd;
            ASSERT_LT(stretches.size(), 100000u);
        }
        ++rays;
        for (int k = 0; k < 2000; ++k) {
            float t = 8.0f * (k + 0.5f) / 2000;
            MediumSample m = ctx.volumes.sample(o + d * t);
            float sigma = nbMaxComponent(m.sigma_t);
            if (sigma <= 0.0f)
                continue;
            ++checkedInside;
            const Stretch* s = nullptr;
            for (const Stretch& st : stretches)
                if (t >= st.t0 && t <= st.t1)
                    s = &st;
            ASSERT_NE(s, nullptr) << "extinction " << sigma << " at t " << t << " outside every stretch, ray " << r;
            ASSERT_LE(sigma, s->maj * (1 + 1e-6f)) << "ray " << r << " t " << t;
        }
    }
    EXPECT_GT(checkedInside, 20000);
    std::printf("%d rays, %d points with extinction checked\n", rays, checkedInside);
}
