// Charts.h: error_vs_time.png and sheet.png of `nimbus compare`, drawn by matplotlib: the
// script compare_charts.py (installed in share/nimbus/compare/, found by src/core/DataFiles.h)
// run with Debian's /usr/bin/python3 on the directory compare wrote. Private to src/compare.
//
// matplotlib is a hard dependency of these two files (scripts/install-deps.sh installs
// python3-matplotlib): one drawing of each chart, with the titles, axis labels, legend and
// colour bar that a hand-rasterised chart lacked, rather than a second, poorer one to fall back
// on. Its failure costs only the charts: compare.csv, summary.md and panels/ are written first.
#pragma once

#include <string>

namespace nimbus {

struct ChartInputs {
    std::string dir;             // holds compare.csv and panels/ (Sheet.h)
    std::string title;           // the scene's name
    double referenceNoise = 0;   // the reference's own beauty relMSE: the chart's floor
    std::string wkbModel;        // "source/kernel" of the sheet's WKB panel
};

// The interpreter the script runs with: Debian's, where python3-matplotlib installs.
inline constexpr const char* kChartPython = "/usr/bin/python3";

// Runs the script (posix_spawn, no shell: the arguments need no quoting) and waits for it.
// Returns "" when it wrote both PNGs, else one line naming the script and why (the script's own
// message is on stderr before it). Never throws for the script's failure.
std::string drawCompareCharts(const ChartInputs& in, const std::string& script);

}  // namespace nimbus
