// The focused light pass (src/vrl/VrlLightPass.h, setFocus; ViewFocus.h): aiming a share of the
// paths at a sphere must leave every expectation where it was. For each light type that is aimed
// (distant, environment, point, spot), the flux that the light's first segments carry through a
// small box, sum of flux over the segments whose line crosses it, is estimated with and without
// a focus; the two must agree within four standard errors for a box inside the focus and for one
// far outside it (where the focused pass sends few paths with more flux each). The same statistic
// must reject a focused estimate scaled by 1.05 on the box inside the focus (so 5% is
// resolvable), and the focus must send several times more segments through that box. The same for
// a point light aimed at the volumes' bounding sphere (setAimAtVolumes) without a focus.
//
// And findViewFocus: a narrow camera on a large slab gives a focus around what it sees; a camera
// that sees the whole volume gives none; traceOrders3 reports which (`--explain`'s line).
#include "../render/SceneBuilders.h"

#include "pathtracer/PathtraceScene.h"
#include "render/RenderContext.h"
#include "render/RenderStats.h"
#include "vrl/Orders3Grid.h"
#include "vrl/ViewFocus.h"
#include "vrl/VrlLightPass.h"
#include "vrl/VrlMedium.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace nimbus;

namespace {

// An 8 x 1 x 8 m slab (sigma_t 20 per m, albedo 0.8) seen through a 6 degree lens from 3.5 m above
// its top face: the camera sees about 0.35 m of it.
Scene slabScene(const Light& light)
{
    Scene s = test::emptyScene(16, 16);
    s.camera.from = make_float3(0.0f, 4.0f, 0.5f);
    s.camera.to = make_float3(0, 0.5f, 0);
    s.camera.fov = 6;
    s.lights.push_back(light);
    s.volumes.push_back(test::homogeneousBox(8.0f, 1.0f, 8.0f, 0.125f, splat(16.0f), splat(4.0f)));
    return s;
}

struct Estimate {
    double mean = 0, se = 0;
    long crossing = 0;  // segments whose line crossed the box
};

// Sum over the light's first segments of flux (channel mean) times [the line crosses box b], per
// batch, over `batches` batches of `paths` paths: its mean per batch and standard error.
Estimate throughBox(const RenderContext& ctx, const vrl::EmissionFocus& focus, const Bbox& b, int batches, int paths,
                    bool aimAtVolumes = false)
{
    PathtraceScene ps = buildPathtraceScene(ctx);
    vrl::VrlMedium medium(ps);
    vrl::LightPass pass(ctx, ps, medium, 2);  // max_depth 2: the first segments only
    pass.setFocus(focus);
    pass.setAimAtVolumes(aimAtVolumes);
    double s1 = 0, s2 = 0;
    long crossing = 0;
    for (int k = 0; k < batches; ++k) {
        double sum = 0;
        for (const vrl::Vrl& v : pass.trace(9, uint32_t(k), paths)) {
            if (v.order != 0)
                continue;
            float a, c;
            const float3 inv = make_float3(1.0f / v.dir.x, 1.0f / v.dir.y, 1.0f / v.dir.z);
            if (b.intersect(v.origin, inv, 0.0f, INFINITY, a, c) && c > a) {
                sum += (v.flux.x + v.flux.y + v.flux.z) / 3.0;
                ++crossing;
            }
        }
        s1 += sum;
        s2 += sum * sum;
    }
    Estimate e;
    e.mean = s1 / batches;
    e.se = std::sqrt(std::max(0.0, s2 / batches - e.mean * e.mean) / (batches - 1));
    e.crossing = crossing;
    return e;
}

Bbox box(float3 c, float h)
{
    Bbox b;
    b.lo = c - splat(h);
    b.hi = c + splat(h);
    return b;
}

void checkLight(const char* name, const Light& light, bool aimAtVolumes = false)
{
    setenv("NIMBUS_CACHE_DIR", (std::string(::testing::TempDir()) + "nimbus-kernel-cache-focus").c_str(), 1);
    const Scene s = slabScene(light);
    const auto ctx = RenderContext::create(s, true);
    vrl::EmissionFocus focus;  // or, with aimAtVolumes, none: the volumes' bounding sphere instead
    focus.active = !aimAtVolumes;
    focus.centre = make_float3(0.0f, 0.5f, 0.0f);
    focus.radius = 0.6f;
    const vrl::EmissionFocus none;
    // (Aimed at the volumes, the gain is smaller: larger boxes and more paths resolve 5%.)
    const Bbox inside = box(make_float3(0.1f, 0.3f, -0.1f), aimAtVolumes ? 1.5f : 0.35f),
               outside = box(make_float3(3.0f, 0.0f, -2.5f), aimAtVolumes ? 0.9f : 0.3f);
    const int batches = aimAtVolumes ? 256 : 128, paths = 16384;
    const Estimate fIn = throughBox(*ctx, focus, inside, batches, paths, aimAtVolumes),
                   nIn = throughBox(*ctx, none, inside, batches, paths);
    const Estimate fOut = throughBox(*ctx, focus, outside, batches, paths, aimAtVolumes),
                   nOut = throughBox(*ctx, none, outside, batches, paths);
    auto z = [](const Estimate& a, const Estimate& b, double scale) {
        return (scale * a.mean - b.mean) / std::sqrt(scale * scale * a.se * a.se + b.se * b.se);
    };
    std::printf("%s: inside the focus %.5g +- %.2g focused, %.5g +- %.2g not (z %+.2f; segments %ld vs %ld); "
                "outside %.5g +- %.2g, %.5g +- %.2g (z %+.2f); focused x 1.05 inside: z %+.2f\n",
                name, fIn.mean, fIn.se, nIn.mean, nIn.se, z(fIn, nIn, 1.0), fIn.crossing, nIn.crossing, fOut.mean,
                fOut.se, nOut.mean, nOut.se, z(fOut, nOut, 1.0), z(fIn, nIn, 1.05));
    ASSERT_GT(nIn.mean, 0.0) << name;
    ASSERT_GT(nOut.mean, 0.0) << name;
    EXPECT_LT(std::fabs(z(fIn, nIn, 1.0)), 4.0) << name;
    EXPECT_LT(std::fabs(z(fOut, nOut, 1.0)), 4.0) << name;
    EXPECT_GT(std::fabs(z(fIn, nIn, 1.05)), 4.0) << name << ": the check cannot resolve 5%";
    EXPECT_GT(fIn.crossing, (aimAtVolumes ? 2 : 3) * nIn.crossing) << name << ": the focus does not aim the paths";
}

}  // namespace

TEST(ViewFocus, AimedDistantLightKeepsItsExpectation)
{
    checkLight("distant", test::distantLight("sun", make_float3(0.3f, -1.0f, 0.2f), splat(2.0f)));
}

TEST(ViewFocus, AimedEnvironmentLightKeepsItsExpectation)
{
    checkLight("environment", test::uniformSky("sky", splat(1.0f)));
}

TEST(ViewFocus, AimedPointLightKeepsItsExpectation)
{
    checkLight("point", test::pointLight("lamp", make_float3(1.5f, 2.5f, 0.5f), splat(4.0f)));
}

TEST(ViewFocus, AimedSpotLightKeepsItsExpectation)
{
    Light l;
    l.type = LightType::Spot;
    l.position = make_float3(2.0f, 3.0f, -1.0f);
    l.direction = normalize(make_float3(-1.0f, -1.2f, 0.5f));
    l.coneAngle = 160.0f;  // wide enough to light the box outside the focus too
    l.intensity = splat(4.0f);
    checkLight("spot", l);
}

// A lamp far from a small volume, no view focus: aimed at the volumes' bounding sphere.
TEST(ViewFocus, PointLightAimedAtTheVolumesKeepsItsExpectation)
{
    checkLight("point aimed at the volumes", test::pointLight("lamp", make_float3(5.0f, 4.0f, -4.0f), splat(40.0f)),
               true);
}

TEST(ViewFocus, NarrowViewOfALargeSlabIsFocusedAndAWholeViewIsNot)
{
    Scene s = slabScene(test::distantLight("sun", make_float3(0, -1, 0), splat(1.0f)));
    auto ctx = RenderContext::create(s, true);
    const vrl::EmissionFocus f = vrl::findViewFocus(*ctx, 0.2f, 6.0f);
    EXPECT_TRUE(f.active);
    // The camera sees about 0.35 m of the top face around (0, 0.5, 0); the margin is two cells here
    // (the slab's diffusion length, 1 / (20 sqrt(3 x 0.2)) = 0.065 m, times 3 is less).
    EXPECT_NEAR(f.centre.x, 0.0f, 0.15f);
    EXPECT_NEAR(f.centre.z, 0.0f, 0.15f);
    EXPECT_GT(f.radius, 0.4f);
    EXPECT_LT(f.radius, 1.0f);
    s.camera.from = make_float3(0.0f, 14.0f, 14.0f);
    s.camera.fov = 60;
    ctx = RenderContext::create(s, true);
    EXPECT_FALSE(vrl::findViewFocus(*ctx, 0.2f, 6.0f).active);
}

// What traceOrders3 reports for `nimbus render --explain` (RenderStats): aimed at the view on the
// narrow view of the slab, with the focus's radius; not on the whole view; and the line printed.
TEST(ViewFocus, TheCacheReportsWhetherItsPathsWereAimed)
{
    setenv("NIMBUS_CACHE_DIR", (std::string(::testing::TempDir()) + "nimbus-kernel-cache-focus").c_str(), 1);
    Scene s = slabScene(test::distantLight("sun", make_float3(0, -1, 0), splat(1.0f)));
    vrl::Orders3Options o;
    o.paths = 2048;
    o.maxCells = 32;
    vrl::Orders3Report narrow, wide;
    {
        const auto ctx = RenderContext::create(s, true);
        const auto grid = vrl::traceOrders3(*ctx, o, &narrow);
        ASSERT_TRUE(grid);
        const vrl::EmissionFocus f = vrl::findViewFocus(*ctx, grid->cellSize(), 1e9f);
        EXPECT_TRUE(narrow.aimedAtView);
        EXPECT_NEAR(narrow.focusRadius, f.radius, 1e-4f);
        EXPECT_GT(narrow.cells, 0u);
    }
    s.camera.from = make_float3(0.0f, 14.0f, 14.0f);
    s.camera.fov = 60;
    {
        const auto ctx = RenderContext::create(s, true);
        ASSERT_TRUE(vrl::traceOrders3(*ctx, o, &wide));
        EXPECT_FALSE(wide.aimedAtView);
    }
    RenderStats stats;
    stats.orders3Cells = narrow.cells;
    stats.orders3SkinCells = narrow.skinCells;
    stats.orders3FocusRadius = narrow.focusRadius;
    EXPECT_NE(stats.describe(RenderPlan{}).find("light paths aimed at the view"), std::string::npos);
    stats.orders3FocusRadius = 0.0f;
    EXPECT_NE(stats.describe(RenderPlan{}).find("light paths over the whole medium"), std::string::npos);
}
