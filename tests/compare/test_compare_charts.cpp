// The glue between `nimbus compare` and its chart script (src/compare/Charts.h, Sheet.h): the
// sheet's panels as files (the difference exact in float), the script found through DataFiles and
// run on what Report.cpp and Sheet.cpp write, and its failure one line naming the script. The
// script's figures themselves are checked by test_compare_charts.py (ctest compare_charts).
#include "compare/Charts.h"
#include "compare/Compare.h"
#include "compare/Report.h"
#include "compare/Sheet.h"
#include "core/DataFiles.h"

#include <OpenImageIO/imagebuf.h>
#include <gtest/gtest.h>

#include <filesystem>

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

// A w x h film whose beauty is a grey ramp times `scale`.
Film ramp(float scale, int w = 8, int h = 6)
{
    Film f;
    f.width = w, f.height = h, f.x1 = w, f.y1 = h;
    Aov& a = f.add("beauty", 4, false);
    a.pixels.assign(size_t(w * h * 4), 1.0f);
    for (int i = 0; i < w * h; ++i)
        for (int c = 0; c < 3; ++c)
            a.pixels[size_t(i) * 4 + size_t(c)] = scale * float(i) / float(w * h);
    return f;
}

CompareRow row(const std::string& method, const std::string& label, double seconds, double relMse)
{
    CompareRow r;
    r.method = method, r.label = label, r.seconds = seconds, r.beauty.relMse = relMse;
    if (method == "wkb")
        r.source = "random_walk", r.kernel = "exact";
    return r;
}

fs::path freshDir(const char* name)
{
    const fs::path d = fs::path(::testing::TempDir()) / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

}  // namespace

TEST(CompareCharts, PanelsHoldThePreviewsAndTheSignedLuminanceDifference)
{
    const fs::path d = freshDir("nimbus-compare-panels");
    const Film ref = ramp(1.0f), wkb = ramp(1.5f), pt = ramp(0.5f);
    writeSheetPanels(ref, wkb, pt, (d / "panels").string());
    for (const char* f : {"reference.png", "wkb.png", "pathtrace.png"})
        EXPECT_GT(fs::file_size(d / "panels" / f), 0u) << f;
    OIIO::ImageBuf diff((d / "panels" / "difference.exr").string());
    ASSERT_TRUE(diff.read(0, 0, true, OIIO::TypeDesc::FLOAT)) << diff.geterror();
    ASSERT_EQ(diff.spec().nchannels, 1);
    EXPECT_EQ(diff.spec().width, 8);
    // Y(wkb) - Y(ref) = 0.5 * ramp, the Rec. 709 weights summing to 1 on grey.
    float d10 = 0;
    diff.getpixel(2, 1, &d10, 1);
    EXPECT_NEAR(d10, 0.5f * 10.0f / 48.0f, 1e-5f);
    EXPECT_THROW(writeSheetPanels(ref, ramp(1.0f, 4, 4), pt, (d / "bad").string()), std::exception);
}

TEST(CompareCharts, TheScriptDrawsBothChartsFromWhatCompareWrites)
{
    const fs::path d = freshDir("nimbus-compare-charts");
    std::vector<CompareRow> rows;
    for (double t : {0.5, 1.0, 2.0})
        rows.push_back(row("pathtrace", "t=" + nimbus::fmt("%g", t) + "s", t, 0.04 / t));
    rows.push_back(row("wkb", "base", 0.3, 0.02));
    rows.push_back(row("wkb", "coarse", 0.1, 0.05));
    rows.push_back(row("single", "base", 0.05, 0.3));
    rows.push_back(row("pathtrace", "equal-time", 0.3, 0.13));
    writeCsv(rows, (d / "compare.csv").string());
    writeSheetPanels(ramp(1.0f), ramp(1.2f), ramp(0.9f), (d / "panels").string());

    ChartInputs in{d.string(), "a scene with spaces.json", 1e-4, "random_walk/exact"};
    const std::string script = dataPath(DataFile::CompareCharts);
    EXPECT_TRUE(fs::is_regular_file(script)) << script;
    EXPECT_EQ(drawCompareCharts(in, script), "");
    for (const char* f : {"error_vs_time.png", "sheet.png"})
        EXPECT_TRUE(fs::is_regular_file(d / f)) << f;

    // Without the CSV: one line naming the script and its exit status, nothing thrown.
    in.dir = freshDir("nimbus-compare-charts-empty").string();
    const std::string err = drawCompareCharts(in, script);
    EXPECT_NE(err.find(script), std::string::npos) << err;
    EXPECT_NE(err.find("exited with status 1"), std::string::npos) << err;
    EXPECT_EQ(err.find('\n'), std::string::npos) << err;
}
