// ExrWriter.h: a Film as one multi-layer scanline OpenEXR file.
//
// Layout (docs/output.md has the table): every AOV is a layer with channels "<aov>.R",
// "<aov>.G", "<aov>.B" ("<aov>.A" too for 4-channel AOVs such as beauty); a 1-channel AOV
// (alpha, depth, variance) repeats its value in all three so that every reader that expects
// colour layers shows it. The beauty is also written as the plain R, G, B, A that viewers show
// by default. Colour channels are half, data AOVs (Aov::isData) float. Data window = the film's
// crop, display window = the full frame. Film metadata become string attributes "nimbus:<key>".
#pragma once

#include <string>

namespace nimbus {

struct Film;

// Writes `film` to `path` through a temporary file in the same directory that is renamed over
// `path` once complete; missing parent directories are created. On any failure throws Error (one
// line naming `path`), removes the temporary file and leaves an existing file at `path` untouched.
void writeExr(const Film& film, const std::string& path);

}  // namespace nimbus
