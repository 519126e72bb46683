// Sheet.h: the panels of sheet.png of `nimbus compare`, written as files for the chart script
// (compare_charts.py, Charts.h), which lays them out with titles and a colour bar. Private to
// src/compare.
#pragma once

#include "../render/Film.h"

#include <string>

namespace nimbus {

// Writes into `dir` (created if missing):
//   reference.png, wkb.png, pathtrace.png   each film's beauty through the preview transform
//                                           (src/io/Preview.h, the shipped config's default view)
//   difference.exr                          signed luminance WKB - reference (Rec. 709 weights,
//                                           FilmAccess.h lum), one float channel "Y", in the
//                                           film's linear radiance, W/(m^2 sr)
// Each file whole or not at all. Throws Error when a film has no beauty or the sizes differ.
void writeSheetPanels(const Film& ref, const Film& wkb, const Film& pt, const std::string& dir);

}  // namespace nimbus
