// ExrReader.h: an EXR that writeExr wrote, read back into a Film: what `nimbus merge` and a
// resumed render (docs/farm.md) read. The inverse of ExrWriter.h's layout: every layer
// "<aov>.R/.G/.B(.A)" or "<aov>.Y|A|Z" becomes an AOV (float channels: a data AOV), the main
// layer's R, G, B, A, Z (copies of beauty and depth) are left out, the data window is the film's
// crop, the display window its size, and "nimbus:<key>" attributes (and worldToCamera,
// worldToNDC) its metadata. Half channels come back as the same values in float, so a film read
// and written again is the same file's pixels bit for bit.
#pragma once

#include "../render/Film.h"

#include <string>

namespace nimbus {

// Throws InputError (one line naming `path`) when the file cannot be read or is not laid out
// as writeExr lays out a film.
Film readExr(const std::string& path);

}  // namespace nimbus
