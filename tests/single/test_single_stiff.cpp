// Single scattering on optically thick ("stiff") voxels against the semi-infinite
// plane-parallel closed form (StiffVoxels.h, marchStiffStep in SingleScatter.cpp).
//
// A slab lit on its top face by a collimated beam of irradiance E (on a surface facing the
// beam), seen from above: with mu0 and mu the cosines of the light's and the view's directions
// to the face normal,
//   L1 = int_0^inf sigma_s E p e^{-tau / mu0} e^{-tau / mu} dtau / (sigma_t mu)
//      = albedo E p(cos Theta) mu0 / (mu0 + mu),
// p normalised to 1 over the sphere and Theta the angle between the light's travel direction
// and the direction toward the camera (Chandrasekhar, Radiative Transfer, sec. 11; Hapke's
// single-scattering term). The voxelised face is a one-voxel density ramp (docs/volumes.md: "the
// box is exact"), which does not change L1: in a plane-parallel medium L1 depends on the optical
// depth only, and the ramp only reshapes depth against optical depth. What the ramp does test is
// the stiff-voxel machinery: a voxel of optical depth 10 to 1000 puts all of L1 inside the
// ramp's first cells, where the lattice's trilinear light optical depth is wrong by up to
// sigma_t h / 8 (StiffVoxels.h); the plain march read those slabs 58-92% dark.
//
// Error budget of the image mean (the 1% bound, not fitted):
//  - the secant sub-step rule: under 0.1% in a one-voxel ramp at sub-steps of <= 0.5 optical
//    depth (kSubStepDepth, StiffVoxels.h); exact in the homogeneous interior;
//  - the cut-off: a ray stops once its transmittance is below render.tolerance (0.002), which
//    drops at most tolerance^(1 + mu / mu0) of L1, under 1e-5 here;
//  - the jitter: inside stiff bricks every sub-step is integrated in closed form, so the
//    jittered lattice only moves where the first sub-step starts: measured over four seeds,
//    the image mean moves by 1e-6 relative (JitterMovesTheSlabsImageMeanByLittle);
//  - float rounding of optical depths (~1e-6 relative in T).
// Measured (2026-12, this branch): -0.03% to -0.10% at voxel optical depth 100, but at 10 up to
// -0.40% near normal incidence (mu0, mu >= 0.8), more than the sub-step rule's 0.1%. That part
// does not come from the sub-steps (it stays at -0.34% with steps ten times shorter), nor from
// the shadow map's tolerance or resolution (unchanged at tolerance 1e-4 or 256^2), and shrinks
// roughly as 1 / (sigma_t h): an open term of the ramp, inside the 1% bound. At voxel optical
// depth 1000 see DeepVoxelsStaySubStepAccurate.
#include "../render/SceneBuilders.h"

#include "../../kernels/shared/rng.h"
#include "engine/Renderer.h"
#include "render/PixelStrata.h"
#include "scene/KernelScene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

using namespace nimbus;
using namespace nimbus::test;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kBound = 0.01;
constexpr float kVoxel = 1.0f / 16;
constexpr float kHalfWidth = 1.5f, kHalfHeight = 0.25f;  // a 3 x 0.5 x 3 m slab, top face y = 0.25

double channel(Rgb v, int c)
{
    return c == 0 ? v.x : (c == 1 ? v.y : v.z);
}

// Henyey-Greenstein, normalised to 1 over the sphere; written here, not taken from phase.h.
double hg(double g, double cosTheta)
{
    return (1.0 - g * g) / (4.0 * kPi * std::pow(1.0 + g * g - 2.0 * g * cosTheta, 1.5));
}

// The angles of one slab view (named apart from nimbus::Geometry, the scene's surfaces).
struct SlabAngles {
    double mu0, mu, azimuthDeg;  // light and view cosines to the face normal; azimuth between them
};

// Unit vector at cosine `mu` to +y and azimuth `phiDeg` about it (0: toward +x).
float3 fromNormal(double mu, double phiDeg)
{
    const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu)), phi = phiDeg * kPi / 180.0;
    return make_float3(float(s * std::cos(phi)), float(mu), float(s * std::sin(phi)));
}

// The slab, a camera 3 m from the top face's centre seeing only a patch of it (1 degree: at
// mu = 0.3 the patch is 0.2 m long, every ray enters > 1.3 m, thousands of mean free paths, from
// a side face) and the light. `light` is a distant light (its direction set here) or a point
// light (its position set here, at `lightDistance` from the face's centre).
Scene slabScene(const SlabAngles& geo, Rgb sigma_s, Rgb sigma_a, float g, Light light, float lightDistance)
{
    Scene s = emptyScene(16, 16);
    s.volumes.push_back(homogeneousBox(2 * kHalfWidth, 2 * kHalfHeight, 2 * kHalfWidth, kVoxel, sigma_s, sigma_a, g));
    const float3 centre = make_float3(0, kHalfHeight, 0);
    const float3 toLight = fromNormal(geo.mu0, 0.0);
    if (light.type == LightType::Distant)
        light.direction = -toLight;
    else
        light.position = centre + toLight * lightDistance;
    light.name = "light";
    s.lights.push_back(light);
    s.camera.from = centre + fromNormal(geo.mu, geo.azimuthDeg) * 3.0f;
    s.camera.to = centre;
    if (geo.mu > 0.99)
        s.camera.up = make_float3(0, 0, 1);  // the default up (+y) is the view direction
    s.camera.fov = 1.0f;
    s.render.spp = 4;
    return s;
}

// The image mean of L1, rendered and from the closed form along each of the renderer's own
// rays (the jittered sample positions are a pure function of seed, pixel and sample), per
// channel. `closedForm(o, d, c)` is L1 along one ray.
template <class ClosedForm>
void meanL1(const Scene& scene, ClosedForm closedForm, double rendered[3], double expected[3])
{
    RenderResult r = render(scene);
    const Aov* L1 = r.film.find("L1");
    ASSERT_NE(L1, nullptr);
    const NbCamera cam = makeNbCamera(scene.camera);
    const int w = scene.camera.width, h = scene.camera.height, spp = scene.render.spp;
    for (int c = 0; c < 3; ++c)
        rendered[c] = expected[c] = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            for (int s = 0; s < spp; ++s) {
                NbRng rng = nbRngStart(scene.render.seed, nb_uint(y * w + x), nb_uint(s));
                // The box filter of width 1: the pixel's point is the offset itself.
                const PixelSampleNumbers u = pixelSampleNumbers(scene.render.seed, nb_uint(y * w + x), s, spp, rng);
                const float jx = u.ux, jy = u.uy, time = u.time;
                float3 o, d;
                nbCameraRay(cam, x + jx, y + jy, w, h, time, &o, &d);
                for (int c = 0; c < 3; ++c)
                    expected[c] += closedForm(o, d, c) / (double(spp) * w * h);
            }
            const float* px = L1->pixels.data() + (size_t(y) * w + x) * 3;
            for (int c = 0; c < 3; ++c)
                rendered[c] += px[c] / (double(w) * h);
        }
}

// The semi-infinite closed form for a distant light of travel direction `dir` and irradiance E,
// along the camera ray d: mu = -d.y, cos Theta = dot(dir, -d).
double distantClosedForm(float3 dir, Rgb E, Rgb albedo, float g, float3 d, int c)
{
    const double mu0 = -dir.y, mu = -d.y, cosTheta = -dot(dir, d);
    return channel(albedo, c) * channel(E, c) * hg(g, cosTheta) * mu0 / (mu0 + mu);
}

struct Case {
    SlabAngles geo;
    double voxelDepth;  // sigma_t h of the densest channel
    Rgb albedo;
    float g;
    Rgb sigmaTRatio = splat(1.0f);  // per channel, times voxelDepth / h
};

// Renders a case lit by a distant light; returns the worst channel's relative error of the
// image mean.
double distantCaseError(const Case& k, uint32_t seed = 1)
{
    const Rgb sigma_t = k.sigmaTRatio * float(k.voxelDepth / kVoxel);
    const Rgb sigma_s = sigma_t * k.albedo, sigma_a = sigma_t - sigma_s;
    const Rgb E = make_float3(1.0f, 2.0f, 0.5f);
    Scene scene = slabScene(k.geo, sigma_s, sigma_a, k.g, distantLight("light", make_float3(0, -1, 0), E), 0.0f);
    scene.render.seed = seed;
    const float3 dir = scene.lights[0].direction;
    double got[3] = {}, want[3] = {};
    meanL1(scene, [&](float3, float3 d, int c) { return distantClosedForm(dir, E, k.albedo, k.g, d, c); }, got, want);
    double worst = 0.0;
    for (int c = 0; c < 3; ++c)
        worst = std::max(worst, std::fabs(got[c] - want[c]) / want[c]);
    std::printf("mu0 %.2f mu %.2f phi %3.0f | voxel tau %6.0f | albedo %.2f %.2f %.2f g %+.1f | L1 %.5f %.5f %.5f vs "
                "%.5f %.5f %.5f | worst %+.3f%%\n",
                k.geo.mu0, k.geo.mu, k.geo.azimuthDeg, k.voxelDepth, k.albedo.x, k.albedo.y, k.albedo.z, k.g, got[0],
                got[1], got[2], want[0], want[1], want[2],
                100.0 * (std::fabs(got[0] - want[0]) > std::fabs(got[2] - want[2])
                             ? (got[0] - want[0]) / want[0]
                             : (got[2] - want[2]) / want[2]));
    return worst;
}

}  // namespace

// The view and light geometry, including a grazing view (mu 0.3) and forward and backward
// scattering, at voxel optical depths 10 and 100: the answer must not change with the voxel's
// optical depth (a semi-infinite slab's L1 does not depend on sigma_t at all).
const SlabAngles kGeometries[] = {{0.8, 0.9, 0}, {0.6, 0.3, 180}, {0.5, 0.7, 90}, {0.9, 0.3, 45}, {1.0, 1.0, 0}};

TEST(SingleStiff, SemiInfiniteSlabMatchesTheClosedFormAtAnyVoxelDepth)
{
    for (const SlabAngles& geo : kGeometries)
        for (double voxelDepth : {10.0, 100.0}) {
            const double err = distantCaseError({geo, voxelDepth, splat(0.95f), 0.3f});
            EXPECT_LT(err, kBound) << "mu0 " << geo.mu0 << " mu " << geo.mu << " azimuth " << geo.azimuthDeg
                                   << " voxel optical depth " << voxelDepth;
        }
}

// Voxel optical depth 1000, the same geometries. A camera step of half a voxel is 500 optical
// depths, and StiffVoxels gives a brick at most kMaxSubSteps = 64 sub-steps per camera step, so
// the sub-steps carry 7.8 optical depths, not kSubStepDepth = 0.5: measured -0.22% to -1.04%
// (fails at mu0 = mu = 1). With render.step 0.05 (sub-steps of 0.78) the same cases read
// -0.01% to -0.03%, which pins the cap as the cause. An open defect, kept as a failing check:
// the bound is the same 1%.
TEST(SingleStiff, DeepVoxelsStaySubStepAccurate)
{
    for (const SlabAngles& geo : kGeometries) {
        const double err = distantCaseError({geo, 1000.0, splat(0.95f), 0.3f});
        EXPECT_LT(err, kBound) << "mu0 " << geo.mu0 << " mu " << geo.mu << " azimuth " << geo.azimuthDeg
                               << ": sub-steps capped at kMaxSubSteps carry more than kSubStepDepth";
    }
}

// Albedo 0.5, 0.95, 1 and HG g -0.3, 0, 0.7: L1 is linear in the albedo and the phase function,
// so every pair must hold the same accuracy.
TEST(SingleStiff, SemiInfiniteSlabMatchesTheClosedFormForAlbedoAndPhase)
{
    const SlabAngles geo{0.7, 0.5, 150};
    for (float albedo : {0.5f, 0.95f, 1.0f})
        for (float g : {-0.3f, 0.0f, 0.7f}) {
            const double err = distantCaseError({geo, 20.0, splat(albedo), g});
            EXPECT_LT(err, kBound) << "albedo " << albedo << " g " << g;
        }
}

// A chromatic medium: sigma_t differs per channel (voxel optical depths 10, 30 and 100), so
// each channel has its own albedo and its own stiffness; each must match its closed form.
TEST(SingleStiff, ChromaticSlabMatchesTheClosedFormPerChannel)
{
    const Case k{{0.8, 0.6, 120}, 100.0, make_float3(0.5f, 0.95f, 1.0f), 0.2f, make_float3(0.1f, 0.3f, 1.0f)};
    EXPECT_LT(distantCaseError(k), kBound);
}

// The jitter's share of the budget: the same case under four seeds moves the image mean by
// far less than the bound (measured spread printed).
TEST(SingleStiff, JitterMovesTheSlabsImageMeanByLittle)
{
    const Case k{{0.6, 0.3, 180}, 10.0, splat(0.95f), 0.3f};
    double lo = 1e30, hi = -1e30;
    for (uint32_t seed : {1u, 2u, 3u, 4u}) {
        const double err = distantCaseError(k, seed);
        lo = std::min(lo, err), hi = std::max(hi, err);
    }
    std::printf("jitter: worst-channel error over 4 seeds in [%.2e, %.2e]\n", lo, hi);
    EXPECT_LT(hi - lo, 0.1 * kBound);
}

// A point light far above (50 m) makes a nearly parallel beam: at each ray's entry into the top
// face the local closed form holds with E = I / r^2 and mu0 the cosine of the direction to the
// light there. What the beam's divergence changes: L1 comes from within delta of the face
// (the ramp's half voxel above it, and below it the depth where the camera's and the light's
// transmittance product has fallen to 1e-3, 7 / (sigma_t (1/mu0 + 1/mu)) < 7 / sigma_t), where
// 1 / r^2 differs from its value at the face by at most 2 delta / r, and mu0 and cos Theta by
// delta / r radians times their derivatives (at most 1 and, for HG g 0.3, 2.1 relative per
// radian). Bound: 1% + (2 + 1 + 2.1) delta / r.
TEST(SingleStiff, PointLightFarAboveMatchesTheClosedFormOfItsLocalBeam)
{
    const double voxelDepth = 10.0, r = 50.0;
    const float g = 0.3f, albedo = 0.95f;
    const double sigma_t = voxelDepth / kVoxel;
    Light bulb;
    bulb.type = LightType::Point;
    bulb.intensity = make_float3(2500.0f, 5000.0f, 1250.0f);  // I / r^2 = 1, 2, 0.5 at the face
    for (const SlabAngles& geo : {SlabAngles{1.0, 0.8, 0}, SlabAngles{0.7, 0.4, 180}}) {
        Scene scene = slabScene(geo, splat(float(sigma_t * albedo)), splat(float(sigma_t * (1 - albedo))), g, bulb,
                                float(r));
        const float3 pos = scene.lights[0].position;
        auto closedForm = [&](float3 o, float3 d, int c) {
            const float3 entry = o + d * ((kHalfHeight - o.y) / d.y);  // on the face, y = top
            const float3 toLight = pos - entry;
            const double dist = length(toLight);
            const float3 dir = -toLight / float(dist);  // the light's travel direction there
            const double mu0 = -dir.y, mu = -d.y, cosTheta = -dot(dir, d);
            return albedo * channel(bulb.intensity, c) / (dist * dist) * hg(g, cosTheta) * mu0 / (mu0 + mu);
        };
        double got[3] = {}, want[3] = {};
        meanL1(scene, closedForm, got, want);
        const double delta = 0.5 * kVoxel + 7.0 / sigma_t;
        const double bound = kBound + (2.0 + 1.0 + 2.1) * delta / r;
        for (int c = 0; c < 3; ++c) {
            const double err = (got[c] - want[c]) / want[c];
            EXPECT_LT(std::fabs(err), bound) << "channel " << c << " mu0 " << geo.mu0 << " mu " << geo.mu;
            std::printf("point light mu0 %.2f mu %.2f channel %d: L1 %.5f vs %.5f, %+.3f%% (bound %.2f%%)\n", geo.mu0,
                        geo.mu, c, got[c], want[c], 100.0 * err, 100.0 * bound);
        }
    }
}
