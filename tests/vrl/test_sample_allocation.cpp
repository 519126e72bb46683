// vrl's camera paths per iteration (src/vrl/SampleAllocation.h): the closed-form choice is the
// least work x variance over every count, checked by brute force; the fallbacks; and on renders,
// the pilot that measures the terms gives thin haze (gathers costly, L1 a large part of the
// image) more camera paths than a medium-dense sphere (L2plus most of the noise), the same
// count on any thread count, and the count in the image's metadata.
#include "engine/Renderer.h"
#include "vrl/SampleAllocation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <variant>

using namespace nimbus;
using nimbus::vrl::chooseCameraPaths;
using nimbus::vrl::PilotMeasure;

namespace {

double product(const PilotMeasure& m, int k)
{
    return (k * m.cameraWork + m.restWork) * (m.cameraVariance / k + m.restVariance);
}

TEST(SampleAllocation, ClosedFormIsTheBruteForceMinimum)
{
    std::mt19937 gen(7);
    std::uniform_real_distribution<double> logUniform(-3.0, 3.0);
    for (int trial = 0; trial < 2000; ++trial) {
        PilotMeasure m;
        m.cameraVariance = std::pow(10.0, logUniform(gen));
        m.restVariance = std::pow(10.0, logUniform(gen));
        m.cameraWork = std::pow(10.0, logUniform(gen));
        m.restWork = std::pow(10.0, logUniform(gen));
        int best = 1;
        for (int k = 2; k <= vrl::kMaxCameraPaths; ++k)
            if (product(m, k) < product(m, best))
                best = k;
        const int chosen = chooseCameraPaths(m, 16);
        // Equal products (a tie between two integers) may go either way.
        EXPECT_LE(product(m, chosen), product(m, best) * (1 + 1e-12)) << "trial " << trial;
    }
}

TEST(SampleAllocation, BalancesWorkAndVariance)
{
    // K* = sqrt(v_k c_r / (v_r c_k)): 4 here, and 1 where the camera paths cost as much as the rest.
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{1.0, 1.0, 1.0, 16.0}, 16), 4);
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{0.25, 1.0, 1.0, 1.0}, 16), 1);
    // Far beyond the cap: the cap.
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{1.0, 1e-6, 1.0, 1e4}, 16), vrl::kMaxCameraPaths);
}

TEST(SampleAllocation, FallsBackWhereThereIsNothingToWeigh)
{
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{}, 16), 1);                     // no variance at all
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{0.0, 1.0, 1.0, 1.0}, 16), 1);   // L1 does not vary
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{1.0, 0.0, 1.0, 1.0}, 16), 16);  // no L2plus (max_depth 1)
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{1.0, 1.0, 1.0, 0.0}, 16), 16);  // no work besides the paths
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{nan, 1.0, 1.0, 1.0}, 16), 16);
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{1.0, -1.0, 1.0, 1.0}, 16), 16);
    EXPECT_EQ(chooseCameraPaths(PilotMeasure{1.0, 1.0, INFINITY, 1.0}, 16), 16);
}

Scene pilotScene(bool haze, int threads)
{
    Scene s;
    s.camera.width = 24;
    s.camera.height = 24;
    s.camera.from = make_float3(0, 0.3f, haze ? 3.2f : 3.5f);
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 45;
    Volume v;
    v.name = "medium";
    v.source.type = SourceType::Procedural;
    Light l;
    l.name = "lamp";
    l.type = LightType::Point;
    l.intensity = splat(4.0f);
    if (haze) {  // bench_vrl's haze_lamp: a 4 m box, sigma_t 0.33 per m, the lamp inside
        v.source.generator = "box";
        v.source.params = {{"size", 4.0}, {"voxel_size", 0.125}};
        v.medium.sigma_s = splat(0.3f);
        v.medium.sigma_a = splat(0.03f);
        v.medium.phase = NbPhase{0.3f, 0, 0, 0};
        l.position = make_float3(0.3f, 0.2f, -0.5f);
    } else {  // bench_vrl's medium_sphere: radius 1 m, sigma_t 2 per m, the lamp outside
        v.source.generator = "sphere";
        v.source.params = {{"radius", 1.0}, {"voxel_size", 0.05}, {"falloff", 0.05}};
        v.medium.sigma_s = splat(1.9f);
        v.medium.sigma_a = splat(0.1f);
        v.medium.phase = NbPhase{0.5f, 0, 0, 0};
        l.position = make_float3(1.5f, 1.0f, 0.4f);
    }
    s.volumes.push_back(v);
    s.lights.push_back(l);
    s.render.method = Method::Vrl;
    s.render.spp = 1;
    s.render.threads = threads;
    s.output.file = "unused.exr";
    return s;
}

int cameraPathsOf(const RenderResult& r)
{
    const FilmValue* v = r.film.meta("vrl_camera_paths");
    if (!v)
        return -1;
    if (const int* i = std::get_if<int>(v))
        return *i;
    return -2;
}

TEST(SampleAllocation, ThinHazeGetsMoreCameraPathsThanADenseSphere)
{
    for (uint32_t seed : {1u, 2u, 3u}) {
        Scene haze = pilotScene(true, 0), sphere = pilotScene(false, 0);
        haze.render.seed = sphere.render.seed = seed;
        const int k = cameraPathsOf(render(haze)), j = cameraPathsOf(render(sphere));
        EXPECT_GE(k, 8) << "seed " << seed;
        EXPECT_LE(j, 6) << "seed " << seed;
        EXPECT_GT(k, 2 * j) << "seed " << seed;
    }
}

TEST(SampleAllocation, SameChoiceOnAnyThreadCount)
{
    const int one = cameraPathsOf(render(pilotScene(false, 1)));
    const int three = cameraPathsOf(render(pilotScene(false, 3)));
    EXPECT_GE(one, 1);
    EXPECT_EQ(one, three);
}

}  // namespace
