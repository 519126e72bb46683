// The error metrics and the time-to-error interpolation of `nimbus compare`.
#include "compare/Compare.h"
#include "compare/ReferenceCache.h"
#include "scene/DefaultScene.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nimbus;

namespace {

Film flat(float v, int w = 4, int h = 2)
{
    Film f;
    f.width = w, f.height = h, f.x1 = w, f.y1 = h;
    Aov& a = f.add("L1", 3, false);
    a.pixels.assign(size_t(w * h * 3), v);
    return f;
}

}  // namespace

TEST(CompareMetrics, ZeroForIdenticalAndRelativeForScaled)
{
    Film ref = flat(2.0f), same = flat(2.0f), high = flat(2.2f);
    ErrorMetrics e = measureError(same, ref, "L1");
    EXPECT_EQ(e.relMse, 0.0);
    EXPECT_EQ(e.energyRel, 0.0);
    e = measureError(high, ref, "L1");
    EXPECT_NEAR(e.energyRel, 0.1, 1e-6);
    EXPECT_NEAR(e.meanRel, 0.1, 1e-6);
    // (0.2)^2 / (4 + eps), eps = (0.1 * 2)^2 = 0.04
    EXPECT_NEAR(e.relMse, 0.04 / 4.04, 1e-6);
}

TEST(CompareMetrics, MissingAovThrows)
{
    Film ref = flat(1.0f), x = flat(1.0f);
    EXPECT_THROW(measureError(x, ref, "L2plus"), std::exception);
}

TEST(CompareMetrics, PathtracerTimeToErrorInterpolatesAndExtrapolatesAsOneOverT)
{
    std::vector<CompareRow> rows;
    for (auto [t, e] : {std::pair{1.0, 0.1}, std::pair{4.0, 0.025}}) {
        CompareRow r;
        r.method = "pathtrace";
        r.label = "t=" + std::to_string(t);
        r.seconds = t;
        r.beauty.relMse = e;
        rows.push_back(r);
    }
    EXPECT_NEAR(ptTimeToError(rows, 0.05), 2.0, 1e-9);
    EXPECT_NEAR(ptTimeToError(rows, 0.0025), 40.0, 1e-9);
    EXPECT_NEAR(ptTimeToError(rows, 0.2), 0.5, 1e-9);
}

// Against a reference of its own noise `floor`, the path tracer's relMSE is floor + c / t: the
// extrapolation beyond the ladder takes c from the ladder's end and keeps the floor, so a ladder
// made of that law gives back its exact times, and an error under the floor is never reached.
TEST(CompareMetrics, PathtracerTimeToErrorKeepsTheReferencesFloor)
{
    const double floor = 0.01, c = 0.1;
    std::vector<CompareRow> rows;
    for (double t : {1.0, 2.0, 4.0}) {
        CompareRow r;
        r.method = "pathtrace";
        r.label = "t=" + std::to_string(t);
        r.seconds = t;
        r.beauty.relMse = floor + c / t;
        rows.push_back(r);
    }
    EXPECT_NEAR(ptTimeToError(rows, floor + c / 10.0, floor), 10.0, 1e-9);
    EXPECT_NEAR(ptTimeToError(rows, floor + c / 0.5, floor), 0.5, 1e-9);
    // The same ladder read as 1/t overall (no floor) reaches 0.02 at 4 x 0.035 / 0.02 = 7 s, not 10.
    EXPECT_NEAR(ptTimeToError(rows, 0.02), 7.0, 1e-9);
    EXPECT_TRUE(std::isinf(ptTimeToError(rows, 0.5 * floor, floor)));
    // A floor over the ladder's last step (overestimated): the 1/t law of the whole relMSE.
    EXPECT_NEAR(ptTimeToError(rows, 0.0175, 0.04), 4.0 * 0.035 / 0.0175, 1e-9);
}

// The reference is the path tracer's: keys only WKB or vrl read must not key a new reference
// (comparing WKB's models on one scene shares one), keys the path tracer reads must.
TEST(CompareReferenceCache, KeyedByWhatThePathTracerReads)
{
    const Scene base = defaultScene();
    const std::string path = referenceCachePath(base, "/tmp/c");
    Scene wkb = base;
    wkb.render.wkbOrders3 = wkb.render.wkbOrders3 == WkbOrders3::Kernel ? WkbOrders3::Traced : WkbOrders3::Kernel;
    wkb.render.wkbKernel = WkbKernel::Gaussian;
    wkb.render.vrlPaths = 3;
    EXPECT_EQ(referenceCachePath(wkb, "/tmp/c"), path);
    Scene medium = base;
    medium.volumes.at(0).medium.sigma_s = splat(0.5f);
    EXPECT_NE(referenceCachePath(medium, "/tmp/c"), path);
    Scene limit = base;
    limit.render.timeLimit = 7.0;
    EXPECT_NE(referenceCachePath(limit, "/tmp/c"), path);
}
