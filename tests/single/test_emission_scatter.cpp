// Emission lights the medium (issue 13, item 4; src/single/EmissionScatter.cpp): emission's single
// scattering against a closed form deep inside an infinite medium and against an independent
// brute-force estimate in a homogeneous box (analytic intersections and transmittances, nothing
// of nimbus's marchers), and in the render: single's and wkb's L1 carry it, wkb's L1 is single's.
#include "../render/HandMadeVolume.h"

#include "engine/Renderer.h"
#include "render/RenderContext.h"
#include "single/EmissionScatter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace nimbus;
using namespace nimbus::test;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The emission grid of a hand-made volume: `S` (W/(m^3 sr)) in every voxel of [0, n)^3.
void fillEmission(VolumeData& v, int n, float S)
{
    const int nb = (n + BrickGrid::kBrick) / BrickGrid::kBrick + 1;
    v.emission.reset({-1, -1, -1}, {nb, nb, nb}, 3);
    for (int bz = 0; bz < nb; ++bz)
        for (int by = 0; by < nb; ++by)
            for (int bx = 0; bx < nb; ++bx) {
                float* vals = v.emission.allocateBrick(bx, by, bz);
                const int kS = BrickGrid::kStored;
                for (int z = 0; z < kS; ++z)
                    for (int y = 0; y < kS; ++y)
                        for (int x = 0; x < kS; ++x) {
                            const int i = (bx - 1) * 8 + x, j = (by - 1) * 8 + y, k = (bz - 1) * 8 + z;
                            const bool inside = i >= 0 && j >= 0 && k >= 0 && i < n && j < n && k < n;
                            for (int c = 0; c < 3; ++c)
                                vals[((z * kS + y) * kS + x) * 3 + c] = inside ? S : 0.0f;
                        }
            }
    v.emission.pruneZeroBricks();
    v.emission.updateMajorants();
}

struct Box {
    Scene scene;
    std::unique_ptr<RenderContext> ctx;
};

// A homogeneous emitting cube of n voxels of size 1/n from the origin: sigma_t c, albedo omega,
// HG g, emission S; no lights.
Box emittingCube(int n, float c, float omega, float g, float S)
{
    Box b;
    b.scene.camera.width = 4;
    b.scene.camera.height = 4;
    b.scene.render.method = Method::Single;
    b.scene.output.file = "unused.exr";
    Medium m;
    m.sigma_s = splat(omega * c);
    m.sigma_a = splat((1 - omega) * c);
    m.phase = NbPhase{g, 0, 0, 0};
    auto vol = handMadeVolume(
        n, 1.0f / n, make_float3(0, 0, 0), [](int, int, int) { return 1.0f; }, m);
    fillEmission(*vol, n, S);
    b.ctx = std::make_unique<RenderContext>();
    b.ctx->scene = &b.scene;
    b.ctx->volumes = VolumeSet({vol}, b.scene.render.step);
    return b;
}

}  // namespace

// Deep inside an infinite homogeneous medium emitted radiance is S / c in every direction, so
// L1 = int T b ds * S / c = omega S / c, whatever the phase function; every sample sees the same
// value, so the estimate is exact up to the march's cut-offs (transmittance 1e-4).
TEST(EmissionScatter, DeepInsideAMediumIsOmegaSOverC)
{
    const float c = 60.0f, omega = 0.7f, S = 2.0f;  // the cube's optical half-width: 30
    Box b = emittingCube(48, c, omega, 0.6f, S);
    const EmissionScatter e(*b.ctx);
    ASSERT_TRUE(e.active());
    const double exact = omega * S / c;
    for (int k = 0; k < 8; ++k) {
        NbRng rng = nbRngStart(3u, nb_uint(k), 0u);
        CameraSample cs;
        const float3 d = normalize(make_float3(0.2f * k - 0.7f, 0.3f, 1.0f));
        e.add(make_float3(0.5f, 0.5f, 0.5f), d, rng, cs);
        EXPECT_NEAR(cs.L1.y, exact, 1e-3 * exact) << k;
        EXPECT_EQ(cs.L0.y, 0.0f);  // L0 (emission seen directly) is marchSingle's, not this term's
    }
}

namespace {

// The cube [lo, hi]^3 as the trilinear voxels make it: constant to the outer voxel centres, a
// one-voxel linear ramp to 0 across each face; its equivalent sharp faces lie half a voxel out.
struct SharpBox {
    double lo, hi;
    bool interval(const double o[3], const double d[3], double& t0, double& t1) const
    {
        t0 = 0.0;
        t1 = 1e30;
        for (int a = 0; a < 3; ++a) {
            if (std::fabs(d[a]) < 1e-15) {
                if (o[a] < lo || o[a] > hi)
                    return false;
                continue;
            }
            double ta = (lo - o[a]) / d[a], tb = (hi - o[a]) / d[a];
            if (ta > tb)
                std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
        }
        return t1 > t0;
    }
};

double hg(double g, double cosTheta)
{
    return (1.0 - g * g) / (4.0 * kPi * std::pow(1.0 + g * g - 2.0 * g * cosTheta, 1.5));
}

}  // namespace

// A camera outside the cube: brute force by uniform sphere directions (weight p / (1/4pi)) and the
// exact Le = S/c (1 - e^{-c len}), points by e^{-c s} along the chord. Agreement within the two
// estimates' noise (4 sigma) plus 2% for the faces' one-voxel ramp, which the brute force treats as
// sharp faces.
TEST(EmissionScatter, MatchesBruteForceInAHomogeneousCube)
{
    const int n = 32;
    const double c = 3.0, omega = 0.8, g = 0.4, S = 1.5;
    Box b = emittingCube(n, float(c), float(omega), float(g), float(S));
    const EmissionScatter e(*b.ctx);
    const SharpBox box{-0.5 / n, 1.0 - 0.5 / n};
    const double o[3] = {0.3, 0.6, -2.0};
    const double targets[4][3] = {{0.5, 0.5, 0.5}, {0.2, 0.7, 0.4}, {0.8, 0.15, 0.6}, {0.05, 0.9, 0.3}};
    std::mt19937_64 gen(99);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    for (int r = 0; r < 4; ++r) {
        double d[3], len2 = 0;
        for (int a = 0; a < 3; ++a) {
            d[a] = targets[r][a] - o[a];
            len2 += d[a] * d[a];
        }
        for (double& v : d)
            v /= std::sqrt(len2);
        // Brute force.
        double t0, t1;
        ASSERT_TRUE(box.interval(o, d, t0, t1));
        const int N = 400000;
        double sum = 0, sum2 = 0;
        for (int i = 0; i < N; ++i) {
            const double mass = -std::expm1(-c * (t1 - t0));
            const double s = -std::log1p(-U(gen) * mass) / c;
            const double pdf = c * std::exp(-c * s) / mass;
            const double x[3] = {o[0] + d[0] * (t0 + s), o[1] + d[1] * (t0 + s), o[2] + d[2] * (t0 + s)};
            const double z = 1.0 - 2.0 * U(gen), phi = 2.0 * kPi * U(gen), rr = std::sqrt(std::max(0.0, 1.0 - z * z));
            const double w[3] = {rr * std::cos(phi), rr * std::sin(phi), z};
            double a0, a1;
            const double len = box.interval(x, w, a0, a1) ? a1 : 0.0;
            const double Le = S / c * -std::expm1(-c * len);
            const double cosTheta = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
            const double v = std::exp(-c * s) * omega * c / pdf * hg(g, cosTheta) * 4.0 * kPi * Le;
            sum += v;
            sum2 += v * v;
        }
        const double ref = sum / N, refErr = std::sqrt(std::max(0.0, sum2 / N - ref * ref) / N);
        // nimbus.
        const int M = 20000;
        double s1 = 0, s2 = 0;
        for (int i = 0; i < M; ++i) {
            NbRng rng = nbRngStart(5u, nb_uint(r * M + i), 0u);
            CameraSample cs;
            e.add(make_float3(float(o[0]), float(o[1]), float(o[2])), make_float3(float(d[0]), float(d[1]), float(d[2])),
                  rng, cs);
            s1 += cs.L1.y;
            s2 += double(cs.L1.y) * cs.L1.y;
        }
        const double mean = s1 / M, err = std::sqrt(std::max(0.0, s2 / M - mean * mean) / M);
        EXPECT_NEAR(mean, ref, 0.02 * ref + 4.0 * std::sqrt(err * err + refErr * refErr))
            << "ray " << r << ": nimbus " << mean << " +- " << err << ", brute force " << ref << " +- " << refErr;
    }
}
