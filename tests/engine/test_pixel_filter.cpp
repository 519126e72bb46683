// The pixel filter against an analytic edge, in every integrator. A black, opaque slab covers
// the right half of the frame in front of a uniform background of radiance 1, its left face in
// the plane x = 0 through the camera, so the edge projects to the image's centre column
// x_e = width / 2 exactly. A pixel p (centre p + 1/2) then sees the background through the
// fraction of its filter's mass left of the edge: beauty = CDF(x_e - p - 1/2) (filter.h's
// separable profile). The slab's trilinear face blurs the edge by under half a voxel (0.004 m
// against a 0.45 m pixel: 0.009 pixel, under 0.008 in any pixel's value), within the bound used. Only the two middle
// rows are rendered (a crop), pixels 10-21 of them tested.
#include "../../kernels/shared/filter.h"
#include "../render/SceneBuilders.h"
#include "engine/Renderer.h"
#include "scene/KernelScene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace nimbus;
using namespace nimbus::test;

namespace {

Scene edgeScene(Method method, PixelFilter filter, float width, int spp)
{
    Scene s = emptyScene(32, 8);
    s.camera.from = make_float3(0, 0, 0);
    s.camera.to = make_float3(0, 0, -5);
    s.camera.fov = 40.0f;  // 8 rows span 3.6 m at 5 m: a pixel is 0.45 m there
    s.background = splat(1.0f);
    // x in [0, 4] m (8.8 pixels right of the edge: pixel 21's filter stays inside), y in
    // [-1.5, 1.5] m (3.3 pixels about the middle: rows 3 and 4's filters stay inside), 64 mm
    // (8 voxels, a brick: few null collisions for the path tracer) thick at z = -5; optical
    // depth 64, transmittance 2e-28.
    Volume slab = homogeneousBox(4.0f, 3.0f, 0.064f, 0.008f, splat(0.0f), splat(1000.0f));
    slab.transform = Transform::translate(2.0, 0.0, -5.0);
    const float crop[4] = {0.25f, 0.75f, 0.375f, 0.625f};  // pixels [8, 24) x [3, 5)
    std::copy(crop, crop + 4, s.camera.crop);
    s.volumes.push_back(slab);
    s.render.method = method;
    s.render.pixelFilter = filter;
    s.render.filterWidth = width;
    s.render.spp = spp;
    return s;
}

}  // namespace

class FilterEdge : public ::testing::TestWithParam<Method> {};

TEST_P(FilterEdge, PixelsAreTheFiltersCdfAcrossTheEdge)
{
    struct Case {
        PixelFilter filter;
        float width;
    };
    const int spp = 4096;
    for (Case c : {Case{PixelFilter::Box, 1.0f}, Case{PixelFilter::Box, 2.0f}, Case{PixelFilter::Gaussian, 2.0f},
                   Case{PixelFilter::Gaussian, 4.0f}, Case{PixelFilter::BlackmanHarris, 3.0f}}) {
        RenderResult r = render(edgeScene(GetParam(), c.filter, c.width, spp));
        const Aov* beauty = r.film.find("beauty");
        ASSERT_NE(beauty, nullptr);
        const int type = nbFilterType(c.filter);
        int inside = 0;
        for (int p = 10; p < 22; ++p) {
            const double expected = nbFilterCdf(type, c.width, 16.0f - float(p) - 0.5f);
            // Each sample sees 0 or 1: binomial noise, 4 standard errors (and a floor for p in
            // {0, 1}), plus the half-voxel face (0.005 pixel times the profile's peak < 0.01).
            const double sd = std::sqrt(std::max(expected * (1 - expected), 1e-4) / spp);
            for (int y = 3; y <= 4; ++y) {
                const float v = beauty->pixels[(size_t(y) * 32 + p) * 4];
                EXPECT_NEAR(v, expected, 4 * sd + 0.01) << pixelFilterName(c.filter) << " " << c.width << " pixel " << p
                                                        << "," << y << " (" << methodName(GetParam()) << ")";
                inside += expected > 0.02 && expected < 0.98;
            }
        }
        // A filter wider than a pixel spreads the edge over pixels (the one-pixel box keeps it sharp).
        if (c.width > 1.0f) {
            EXPECT_GE(inside, 4) << "the edge falls between pixels for " << pixelFilterName(c.filter);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Methods, FilterEdge, ::testing::Values(Method::Single, Method::Wkb, Method::Pathtrace),
                         [](const auto& info) { return std::string(methodName(info.param)); });

// The default is a Gaussian of width 2, as in most production renderers.
TEST(PixelFilter, DefaultIsAGaussianOfWidthTwo)
{
    Scene s;
    EXPECT_EQ(s.render.pixelFilter, PixelFilter::Gaussian);
    EXPECT_EQ(s.render.filterWidth, 2.0f);
}
