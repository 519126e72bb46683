// Sheet.h: sheet.png of `nimbus compare`, the reference, WKB and the path tracer side by side
// with WKB's error. Private to src/compare.
#pragma once

#include "../render/Film.h"

#include <string>

namespace nimbus {

// reference | WKB | path tracer at equal time (through the preview transform) | signed
// difference WKB - reference of luminance (blue negative, red positive, full scale = the largest
// |difference|), each panel magnified 4x (nearest pixel).
// tmpDir: where the panels pass through the preview transform (a PNG, removed after).
void writeSheet(const Film& ref, const Film& wkb, const Film& pt, const std::string& path, const std::string& tmpDir);

}  // namespace nimbus
