// Compare.h: `nimbus compare`: error against run time of the path tracer and of WKB, measured
// against a converged path-traced reference (issue 4, docs/validation.md).
//
// Error metrics per AOV (beauty RGB, L1, L2plus), over every pixel and channel of the crop:
//   relMSE      mean of (x - ref)^2 / (ref^2 + eps), eps = (0.1 mean(ref))^2 so that black
//               pixels do not dominate (a fixed fraction of the image's own level);
//   meanRel     sum |x - ref| / sum |ref| (mean relative absolute error);
//   energyRel   (sum x - sum ref) / sum ref, signed (the relative error of total energy).
#pragma once

#include "../render/Film.h"
#include "../scene/Scene.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace nimbus {

struct ErrorMetrics {
    double relMse = 0, meanRel = 0, energyRel = 0;
};

// Errors of `x` against `ref` for one AOV (the first three channels). Throws Error when the
// AOV is missing from either film or the sizes differ.
ErrorMetrics measureError(const Film& x, const Film& ref, const std::string& aov);

// relMSE of the reference's own noise: mean of var / (ref^2 + eps) from its variance AOV (beauty
// luminance variance of the mean); 0 if the film has none.
double referenceNoiseRelMse(const Film& ref);

struct CompareRow {
    std::string method;          // "pathtrace", "wkb", "single"
    std::string label;           // ladder step, e.g. "t=2s", "base", "coarse", "fine"
    std::string source, kernel;  // wkb only
    uint32_t seed = 0;
    double seconds = 0;
    long long spp = 0;
    ErrorMetrics beauty, L1, L2plus;
};

struct CompareOptions {
    std::string outDir = "compare";
    double minutes = 1.0;     // scales the reference's time and the path tracer's time ladder
    double referenceMinutes = 0.0;  // scales the reference's time alone when > 0 (else `minutes`)
    int seeds = 2;            // independent path-tracer seeds per ladder step
    std::string cacheDir;     // empty: $NIMBUS_CACHE_DIR, $XDG_CACHE_HOME/nimbus, ~/.cache/nimbus
    bool fullLadder = false;  // more WKB quality steps
    bool quiet = false;
};

struct CompareResult {
    std::vector<CompareRow> rows;
    double referenceSeconds = 0, referenceNoise = 0;
    bool referenceCached = false;
    // Why error_vs_time.png and sheet.png were not drawn (Charts.h), "" when they were: every
    // other file is written all the same.
    std::string chartsError;
};

// The whole comparison for a validated scene; writes compare.csv, summary.md, panels/ (the
// sheet's images), reference.exr (when rendered) and, drawn by matplotlib from those,
// error_vs_time.png and sheet.png under options.outDir. A failure to draw the charts is
// reported in CompareResult::chartsError, not thrown.
CompareResult runCompare(const Scene& scene, const CompareOptions& options);

// Path-tracer time to reach a relMSE against the reference, from the path tracer's rows: log-log
// interpolation of the seed-averaged beauty relMSE against time; beyond the measured range
// floor + c / t, floor the reference's own relMSE (referenceNoiseRelMse; 0: relMSE ~ 1/t), and
// infinity for a relMSE at or under the floor.
double ptTimeToError(const std::vector<CompareRow>& rows, double relMse, double floor = 0.0);

}  // namespace nimbus
