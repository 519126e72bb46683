// Compare.cpp: runCompare (Compare.h), the runs of `nimbus compare`: the reference (cached,
// ReferenceCache.h), the path tracer at a ladder of times and seeds, WKB for each source model
// and kernel and at a ladder of quality steps, single scattering, and the path tracer at WKB's
// time, and virtual ray lights at the path tracer's ladder and at WKB's time. Each run's errors
// come from ErrorMetrics.cpp; the files are written by Report.cpp and Sheet.cpp, and the charts
// drawn from them by compare_charts.py (Charts.h).
#include "Compare.h"
#include "Charts.h"
#include "FilmAccess.h"
#include "ReferenceCache.h"
#include "Report.h"
#include "Sheet.h"

#include "../core/DataFiles.h"
#include "../core/Error.h"
#include "../engine/Renderer.h"
#include "../io/ExrWriter.h"
#include "../io/Preview.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

CompareRow makeRow(const std::string& method, const std::string& label, const Scene& s, const RenderResult& r,
                   const Film& ref)
{
    CompareRow row;
    row.method = method;
    row.label = label;
    if (method == "wkb") {
        row.source = wkbSourceName(s.render.wkbSource);
        row.kernel = wkbKernelName(s.render.wkbKernel);
    }
    row.seed = s.render.seed;
    row.seconds = r.seconds;
    row.spp = method == "pathtrace" || method == "vrl" ? sppOf(r.film) : (s.render.spp > 0 ? s.render.spp : kDefaultMarchSpp);
    row.beauty = measureError(r.film, ref, "beauty");
    row.L1 = measureError(r.film, ref, "L1");
    row.L2plus = r.film.find("L2plus") ? measureError(r.film, ref, "L2plus") : ErrorMetrics{1, 1, -1};
    return row;
}

}  // namespace

CompareResult runCompare(const Scene& input, const CompareOptions& opt)
{
    CompareResult result;
    fs::create_directories(opt.outDir);
    auto say = [&](const std::string& s) {
        if (!opt.quiet)
            std::fprintf(stderr, "nimbus compare: %s\n", s.c_str());
    };

    // Reference: the path tracer, long, cached by the scene document's hash.
    Scene refScene = input;
    refScene.render.method = Method::Pathtrace;
    refScene.render.spp = 1 << 24;
    refScene.render.maxDepth = 0;  // unbounded whatever the scene says: a depth cap biases the reference
    refScene.render.timeLimit = 45.0 * (opt.referenceMinutes > 0.0 ? opt.referenceMinutes : opt.minutes);
    refScene.render.seed = 0x5eed0001u;
    refScene.output.preview.clear();
    const std::string cachePath = referenceCachePath(refScene, opt.cacheDir);
    Film ref;
    if (loadReference(cachePath, ref) && ref.width == input.camera.width && ref.height == input.camera.height) {
        result.referenceCached = true;
        say("reference from cache " + cachePath);
    } else {
        say("rendering the reference (" + fmt("%.0f", refScene.render.timeLimit) + " s)...");
        RenderResult r = render(refScene);
        ref = r.film;
        result.referenceSeconds = r.seconds;
        saveReference(ref, cachePath);
        writeExr(ref, opt.outDir + "/reference.exr");
    }
    if (ref.x0 != 0 || ref.y0 != 0 || ref.x1 != ref.width || ref.y1 != ref.height)
        throw InputError("compare: the scene must render the full frame (no crop)");
    result.referenceNoise = referenceNoiseRelMse(ref);

    std::vector<CompareRow>& rows = result.rows;
    Scene base = input;
    base.output.preview.clear();

    // (a) The path tracer: K seeds at a ladder of time limits.
    Scene pt = base;
    pt.render.method = Method::Pathtrace;
    pt.render.spp = 1 << 24;
    pt.render.maxDepth = 0;  // the same estimator as the reference, so its error is noise alone
    for (double t : {0.5, 1.0, 2.0, 4.0, 8.0}) {
        const double limit = t * opt.minutes;
        for (int k = 0; k < opt.seeds; ++k) {
            pt.render.timeLimit = limit;
            pt.render.seed = 1000u + uint32_t(k);
            RenderResult r = render(pt);
            rows.push_back(makeRow("pathtrace", "t=" + fmt("%g", limit) + "s", pt, r, ref));
            say("pathtrace " + rows.back().label + " seed " + std::to_string(k) + ": beauty relMSE " +
                fmt("%.3g", rows.back().beauty.relMse));
        }
    }

    // (a') Virtual ray lights (docs/vrl.md) at the same ladder and seeds: the other unbiased
    // estimator, its error against time beside the path tracer's.
    Scene vrl = pt;
    vrl.render.method = Method::Vrl;
    for (double t : {0.5, 1.0, 2.0, 4.0, 8.0}) {
        const double limit = t * opt.minutes;
        for (int k = 0; k < opt.seeds; ++k) {
            vrl.render.timeLimit = limit;
            vrl.render.seed = 1000u + uint32_t(k);
            RenderResult r = render(vrl);
            rows.push_back(makeRow("vrl", "t=" + fmt("%g", limit) + "s", vrl, r, ref));
            say("vrl " + rows.back().label + " seed " + std::to_string(k) + ": beauty relMSE " +
                fmt("%.3g", rows.back().beauty.relMse));
        }
    }

    // (b) WKB: each source model x kernel at the scene's settings, then a quality ladder on the
    // scene's own model.
    Scene wkb = base;
    wkb.render.method = Method::Wkb;
    Film baseWkb;
    double baseWkbSeconds = 0;
    for (WkbSource src : {WkbSource::Straight, WkbSource::RandomWalk})
        for (WkbKernel ker : {WkbKernel::Gaussian, WkbKernel::Exact}) {
            Scene s = wkb;
            s.render.wkbSource = src;
            s.render.wkbKernel = ker;
            RenderResult r = render(s);
            rows.push_back(makeRow("wkb", "base", s, r, ref));
            say(std::string("wkb ") + wkbSourceName(src) + "/" + wkbKernelName(ker) + ": beauty relMSE " +
                fmt("%.3g", rows.back().beauty.relMse) + ", L2plus energy " +
                fmt("%+.3f", rows.back().L2plus.energyRel) + ", " + fmt("%.2f", r.seconds) + " s");
            if (src == input.render.wkbSource && ker == input.render.wkbKernel) {
                baseWkb = r.film;
                baseWkbSeconds = r.seconds;
            }
        }
    struct Step {
        const char* label;
        float lStep;
        int orderMax, lightRes, shadowRes, spp;
    };
    std::vector<Step> ladder = {
        {"coarse", 1.0f, 16, 16, 64, 1}, {"fast", 0.5f, 32, 32, 128, 2}, {"fine", 0.125f, 256, 0, 512, 8}};
    if (opt.fullLadder) {
        ladder.push_back({"lstep0.0625", 0.0625f, 128, 0, 256, 4});
        ladder.push_back({"order8", 0.25f, 8, 0, 256, 4});
        ladder.push_back({"lightres64", 0.25f, 128, 64, 256, 4});
        ladder.push_back({"lightres128", 0.25f, 128, 128, 256, 4});
        ladder.push_back({"smr1024", 0.25f, 128, 0, 1024, 4});
        ladder.push_back({"spp32", 0.25f, 128, 0, 256, 32});
    }
    for (const Step& st : ladder) {
        Scene s = wkb;
        s.render.wkbLStep = st.lStep;
        s.render.wkbOrderMax = st.orderMax;
        s.render.lightVolumeResolution = st.lightRes;
        s.render.shadowMapResolution = st.shadowRes;
        s.render.spp = st.spp;
        RenderResult r = render(s);
        rows.push_back(makeRow("wkb", st.label, s, r, ref));
        say(std::string("wkb ") + st.label + ": beauty relMSE " + fmt("%.3g", rows.back().beauty.relMse) + ", " +
            fmt("%.2f", r.seconds) + " s");
    }
    {
        Scene s = base;
        s.render.method = Method::Single;
        RenderResult r = render(s);
        rows.push_back(makeRow("single", "base", s, r, ref));
    }

    // The path tracer at WKB's time, for the sheet.
    pt.render.timeLimit = std::max(0.05, baseWkbSeconds);
    pt.render.seed = 2000u;
    RenderResult eq = render(pt);
    rows.push_back(makeRow("pathtrace", "equal-time", pt, eq, ref));
    vrl.render.timeLimit = pt.render.timeLimit;
    vrl.render.seed = 2000u;
    RenderResult eqVrl = render(vrl);
    rows.push_back(makeRow("vrl", "equal-time", vrl, eqVrl, ref));

    writeCsv(rows, opt.outDir + "/compare.csv", result.referenceNoise);
    writeSheetPanels(ref, baseWkb, eq.film, opt.outDir + "/panels");
    writePreview(eqVrl.film, opt.outDir + "/panels/vrl.png");
    writeSummary(input, ref, result, opt.outDir + "/summary.md");
    say("wrote " + opt.outDir + "/{compare.csv,summary.md,panels/}");

    ChartInputs charts;
    charts.dir = opt.outDir;
    charts.title = input.sourcePath.empty() ? "nimbus compare" : fs::path(input.sourcePath).filename().string();
    charts.referenceNoise = result.referenceNoise;
    charts.wkbModel = std::string(wkbSourceName(input.render.wkbSource)) + "/" + wkbKernelName(input.render.wkbKernel);
    result.chartsError = drawCompareCharts(charts, dataPath(DataFile::CompareCharts));
    if (result.chartsError.empty())
        say("wrote " + opt.outDir + "/{error_vs_time.png,sheet.png}");
    return result;
}

}  // namespace nimbus
