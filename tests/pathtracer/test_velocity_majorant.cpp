// Velocity motion blur's conditions for unbiased tracking (docs/motion-blur.md), host-side: the
// path tracer's moved lookups (kernels/shared/majorant.h, compiled for the host) agree with the
// host integrators' independent ones (VolumeSet::sampleAt), and the grown, max-filtered
// majorants bound the moved extinction at every point and every shutter time. A uniform velocity
// moves the medium by exactly v s.
#include "PtWorld.h"

#include "../../kernels/shared/majorant.h"
#include "pathtracer/PathtraceScene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

// Sets volume v's velocity (index voxels per second) from f over its table, and maxSpeed.
void setVelocity(VolumeData& v, Int3 nb, std::function<float3(float3)> f)
{
    const float3 n = make_float3(float(8 * nb.x), float(8 * nb.y), float(8 * nb.z));
    v.velocity = gridFrom(nb, 3, [&](int i, int j, int k, int c) {
        return component(f(make_float3(i / n.x, j / n.y, k / n.z)), c);
    });
    v.maxSpeed = 0.0f;
    for (int k = 0; k < 8 * nb.z; ++k)
        for (int j = 0; j < 8 * nb.y; ++j)
            for (int i = 0; i < 8 * nb.x; ++i)
                v.maxSpeed = std::max(v.maxSpeed, length(f(make_float3(i / n.x, j / n.y, k / n.z))));
}

struct Stretch {
    float t0, t1, maj;
};

}  // namespace

TEST(VelocityMajorant, MovedExtinctionIsBoundedAndLookupsAgree)
{
    World w(4, 4);
    const Int3 nb = {3, 3, 3};
    // A lumpy ball with holes, in a swirling, shearing flow of up to ~10 voxels/s.
    auto a = boxVolume(make_float3(-1, -1, -1), make_float3(1, 1, 1), nb, medium(make_float3(1, 2, 3), splat(0.5f)),
                       [](float3 u) {
                           float r = length(u - splat(0.5f));
                           return r < 0.3f ? (0.6f + 0.4f * std::sin(19 * u.x) * std::cos(13 * u.z)) * (r > 0.1f)
                                           : 0.0f;
                       });
    setVelocity(*a, nb, [](float3 u) {
        const float3 c = u - splat(0.5f);
        return make_float3(-c.y * 20.0f + 3.0f, c.x * 20.0f, 6.0f * std::sin(7 * u.x));
    });
    // A still volume beside it: its majorants must stay the static ones.
    auto b = boxVolume(make_float3(0.5f, -0.4f, -0.3f), make_float3(1.4f, 0.6f, 0.5f), {1, 1, 1},
                       medium(splat(3.0f), splat(0.0f)), [](float3 u) { return u.x; });
    w.volumes = {a, b};
    w.context();
    w.ctx->volumes.setShutter(-0.5f, 1.0f);
    const RenderContext& ctx = *w.ctx;
    ASSERT_TRUE(ctx.volumes.moving());
    EXPECT_NEAR(ctx.volumes.maxDisplacement(0), a->maxSpeed * 1.0f, 1e-5f);
    EXPECT_EQ(ctx.volumes.maxDisplacement(1), 0.0f);
    PathtraceScene ps = buildPathtraceScene(ctx);
    ASSERT_TRUE(ps.velocity);
    ASSERT_GT(ps.volumes[0].motionMajorant.dims[3], 0);
    ASSERT_EQ(ps.volumes[1].motionMajorant.dims[3], 0);

    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1, 1), time(0, 1);
    int checked = 0, moved = 0;
    for (int r = 0; r < 300; ++r) {
        const float3 o = make_float3(3 * u(rng), 3 * u(rng), 3 * u(rng));
        const float3 d = normalize(make_float3(0.6f * u(rng), 0.6f * u(rng), 0.6f * u(rng)) - o);
        const float seconds = ctx.volumes.shutterSeconds(time(rng));
        NbMajorantIter it;
        nbMajorantInit(&it, ps.volumes.data(), int(ps.volumes.size()), o, d, 0.0f, NB_INF, seconds, ps.majorants.data());
        std::vector<Stretch> stretches;
        float segEnd = 0, maj = 0;
        while (nbMajorantNext(&it, ps.volumes.data(), ps.majorants.data(), &segEnd, &maj)) {
            stretches.push_back({it.t, segEnd, maj});
            it.t = segEnd;
            ASSERT_LT(stretches.size(), 100000u);
        }
        for (int k = 0; k < 1500; ++k) {
            const float t = 8.0f * (k + 0.5f) / 1500;
            const MediumSample m = ctx.volumes.sampleAt(seconds, o + d * t);
            const float sigma = nbMaxComponent(m.sigma_t);
            if (sigma <= 0.0f)
                continue;
            ++checked;
            if (!(nbMaxComponent(ctx.volumes.sample(o + d * t).sigma_t) == sigma))
                ++moved;
            const Stretch* s = nullptr;
            for (const Stretch& st : stretches)
                if (t >= st.t0 && t <= st.t1)
                    s = &st;
            ASSERT_NE(s, nullptr) << "moved extinction " << sigma << " at t " << t << " outside every stretch, ray "
                                  << r << ", " << seconds << " s";
            ASSERT_LE(sigma, s->maj * (1 + 1e-6f)) << "ray " << r << " t " << t << ", " << seconds << " s";
            // The kernel's moved lookup (nbMajorantDensities) reads the same densities.
            NbMajorantIter at;
            nbMajorantInit(&at, ps.volumes.data(), int(ps.volumes.size()), o, d, 0.0f, NB_INF, seconds, ps.majorants.data());
            float tEnd, mu;
            at.t = t;
            nbMajorantNext(&at, ps.volumes.data(), ps.majorants.data(), &tEnd, &mu);
            at.t = t;
            float rho[NB_NUM_VOLUMES];
            nbMajorantDensities(&at, ps.volumes.data(), ps.tables.data(), ps.pools.data(), rho);
            float kernelSigma = 0.0f;
            for (size_t v = 0; v < ps.volumes.size(); ++v)
                kernelSigma += ps.volumes[v].sigma_t[2] * rho[v];  // channel 2 is the largest here
            ASSERT_NEAR(kernelSigma, m.sigma_t.z, 1e-4f * std::max(1.0f, m.sigma_t.z)) << "ray " << r << " t " << t;
        }
    }
    EXPECT_GT(checked, 5000);
    EXPECT_GT(moved, checked / 4);  // the flow really moves what is checked
    std::printf("%d points with moved extinction checked, %d differ from the frame's\n", checked, moved);
}

TEST(VelocityMajorant, UniformVelocityTranslatesTheMedium)
{
    World w(4, 4);
    const Int3 nb = {4, 2, 2};
    auto a = boxVolume(make_float3(-2, -1, -1), make_float3(2, 1, 1), nb, medium(splat(2.0f), splat(0.0f)),
                       [](float3 u) {
                           const float r = length((u - make_float3(0.5f, 0.5f, 0.5f)) * make_float3(2, 1, 1));
                           return r < 0.4f ? 1.0f - r : 0.0f;
                       });
    const float3 vIndex = make_float3(4.0f, -1.0f, 0.5f);  // index voxels per second
    setVelocity(*a, nb, [&](float3) { return vIndex; });
    w.volumes = {a};
    w.context();
    w.ctx->volumes.setShutter(0.0f, 1.0f);
    const VolumeSet& vs = w.ctx->volumes;
    const float3 vWorld = a->worldFromIndex.vector(vIndex);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1, 1), time(0, 1);
    int inside = 0;
    for (int k = 0; k < 20000; ++k) {
        // Points well inside the velocity grid, so v(q) is the uniform v.
        const float3 p = make_float3(1.4f * u(rng), 0.6f * u(rng), 0.6f * u(rng));
        const float s = vs.shutterSeconds(time(rng));
        const float moved = vs.sampleAt(s, p).sigma_t.x;
        const float translated = vs.sample(p - vWorld * s).sigma_t.x;
        inside += moved > 0.0f;
        ASSERT_NEAR(moved, translated, 2e-5f) << "p " << p.x << " " << p.y << " " << p.z << ", " << s << " s";
    }
    EXPECT_GT(inside, 2000);
}
