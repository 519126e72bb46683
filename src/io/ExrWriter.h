// ExrWriter.h: a Film as one multi-layer scanline OpenEXR file.
//
// Layout (docs/output.md has the table), OpenEXR's conventions: the main layer R, G, B, A is the
// beauty (A its alpha) and Z the depth AOV, what compositors read by default. Every AOV is also
// a layer of its own: "<aov>.R", ".G", ".B" (".A" too for 4-channel AOVs such as beauty), a
// 1-channel AOV one channel named by its meaning ("alpha.A", "depth.Z", "variance.Y"). Colour
// channels are half, data (Aov::isData, and Z) float. Data window = the film's crop, display
// window = the full frame. Film metadata become attributes "nimbus:<key>" of the value's type
// (string, int, double, m44f); "worldToCamera" and "worldToNDC" are OpenEXR's own (m44f).
#pragma once

#include <string>

namespace nimbus {

struct Film;

// Writes `film` to `path` through a temporary file in the same directory that is renamed over
// `path` once complete; missing parent directories are created. On any failure throws Error (one
// line naming `path`), removes the temporary file and leaves an existing file at `path` untouched.
void writeExr(const Film& film, const std::string& path);

// Writes film.deep (DeepFilm.h) as a deep scanline OpenEXR, atomically as writeExr: channels R, G,
// B, A (premultiplied) and Z, ZBack (camera-space depth along the view axis), all float; the data
// and display windows and the metadata as writeExr's, plus "nimbus:deep_samples". Throws Error.
void writeDeepExr(const Film& film, const std::string& path);

}  // namespace nimbus
