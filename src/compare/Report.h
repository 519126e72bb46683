// Report.h: the tables of `nimbus compare`: compare.csv (every run, every seed) and summary.md
// (one row per step, with the path tracer's time to the same error). Private to src/compare.
#pragma once

#include "Compare.h"

#include <string>
#include <vector>

namespace nimbus {

// One number through printf's `format`.
std::string fmt(const char* format, double v);
void writeCsv(const std::vector<CompareRow>& rows, const std::string& path, double referenceNoise = 0.0);
// input: the scene compared (its file name and WKB model); ref: the reference film.
void writeSummary(const Scene& input, const Film& ref, const CompareResult& result, const std::string& path);

}  // namespace nimbus
