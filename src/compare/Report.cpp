// Report.cpp: compare.csv and summary.md (Report.h), each written whole or not at all.
#include "Report.h"
#include "FilmAccess.h"

#include "../core/Error.h"
#include "../io/AtomicFile.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace nimbus {

namespace {

void writeAtomic(const std::string& path, const std::string& text)
{
    AtomicFile file(path);
    if (std::fwrite(text.data(), 1, text.size(), file.stream()) != text.size())
        throw Error("compare: cannot write '" + path + "'");
    file.commit();  // checks the stream's errors and its close too
}

// The summary's "PT time to equal beauty relMSE": infinite where the relMSE is under the reference's floor.
std::string ptSeconds(double t)
{
    return std::isinf(t) ? std::string("never (under the reference's floor)") : fmt("%.2f", t);
}

std::string rowsToCsv(const std::vector<CompareRow>& rows, double floor)
{
    std::ostringstream o;
    o << "method,label,source,kernel,seed,seconds,spp";
    for (const char* a : {"beauty", "L1", "L2plus"})
        o << "," << a << "_relmse," << a << "_meanrel," << a << "_energyrel";
    o << ",pt_seconds_to_equal_beauty_relmse\n";
    for (const CompareRow& r : rows) {
        o << r.method << "," << r.label << "," << r.source << "," << r.kernel << "," << r.seed << ","
          << fmt("%.4f", r.seconds) << "," << r.spp;
        for (const ErrorMetrics* m : {&r.beauty, &r.L1, &r.L2plus})
            o << "," << fmt("%.6g", m->relMse) << "," << fmt("%.6g", m->meanRel) << "," << fmt("%.6g", m->energyRel);
        o << "," << (r.method == "wkb" ? fmt("%.4g", ptTimeToError(rows, r.beauty.relMse, floor)) : std::string()) << "\n";
    }
    return o.str();
}

}  // namespace

std::string fmt(const char* format, double v)
{
    char buf[64];
    std::snprintf(buf, sizeof(buf), format, v);
    return buf;
}

void writeCsv(const std::vector<CompareRow>& rows, const std::string& path, double referenceNoise)
{
    writeAtomic(path, rowsToCsv(rows, referenceNoise));
}

void writeSummary(const Scene& input, const Film& ref, const CompareResult& result, const std::string& path)
{
    const std::vector<CompareRow>& rows = result.rows;
    std::ostringstream md;
    md << "# nimbus compare: " << (input.sourcePath.empty() ? "(scene)" : input.sourcePath) << "\n\n";
    md << "Reference: path tracer, " << sppOf(ref) << " spp"
       << (result.referenceCached ? " (cached)" : ", " + fmt("%.1f", result.referenceSeconds) + " s")
       << "; its own beauty relMSE (from its variance) " << fmt("%.3g", result.referenceNoise)
       << ", the floor under every error below. The path tracer's time to a WKB row's relMSE is "
          "interpolated on its ladder, and beyond it extrapolated as floor + c / t (its own noise falls as "
          "1/t, the reference's stays).\n\n";
    md << "| method | step | source | kernel | time s | beauty relMSE | beauty energy | L1 energy | L2plus energy | "
          "L2plus meanRel | PT time to equal beauty relMSE s |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const CompareRow& r : rows) {
        if ((r.method == "pathtrace" || r.method == "vrl") && r.seed != 1000u && r.label != "equal-time")
            continue;
        md << "| " << r.method << " | " << r.label << " | " << r.source << " | " << r.kernel << " | "
           << fmt("%.2f", r.seconds) << " | " << fmt("%.3g", r.beauty.relMse) << " | "
           << fmt("%+.3f", r.beauty.energyRel) << " | " << fmt("%+.3f", r.L1.energyRel) << " | "
           << fmt("%+.3f", r.L2plus.energyRel) << " | " << fmt("%.3f", r.L2plus.meanRel) << " | "
           << (r.method == "wkb" ? ptSeconds(ptTimeToError(rows, r.beauty.relMse, result.referenceNoise)) : std::string())
           << " |\n";
    }
    md << "\nFiles: compare.csv (every run, every seed), error_vs_time.png, sheet.png (reference | WKB "
       << wkbSourceName(input.render.wkbSource) << "/" << wkbKernelName(input.render.wkbKernel)
       << " | path tracer at WKB's time | WKB - reference, luminance, red brighter, blue darker, full scale the "
          "largest difference, its colour bar in W/(m^2 sr)), panels/ (the sheet's images: PNG through the preview "
          "transform, difference.exr in float).\n";
    writeAtomic(path, md.str());
}

}  // namespace nimbus
