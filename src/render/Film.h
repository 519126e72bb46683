// Film.h: the image buffers a render produces, one per AOV.
//
// AOV names are a contract shared by every integrator (so the path tracer's terms compare one to
// one with the WKB marcher's): "beauty" (RGBA), "L0", "L1", "L2plus", "alpha", "depth",
// "light_<name>" per light, "variance" (pathtrace). Colour AOVs are written as half, data AOVs
// (alpha, depth, variance) as float.
#pragma once

#include "../core/BulkAllocator.h"
#include "../scene/CameraMatrices.h"
#include "DeepFilm.h"

#include <memory>
#include <string>
#include <variant>
#include <vector>

namespace nimbus {

struct Aov {
    std::string name;
    int channels = 3;          // 1 (data) or 3 (RGB); beauty is 4 (RGBA)
    bool isData = false;       // written as float rather than half
    BulkVector<float> pixels;  // row-major from the top-left, channels interleaved
};

// A header attribute: text, an integer, a real, or a 4x4 matrix (OpenEXR's m44f).
using FilmValue = std::variant<std::string, int, double, Matrix44>;

struct Film {
    int width = 0, height = 0;
    // Data window (the crop) in pixels: [x0, x1) x [y0, y1).
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    std::vector<Aov> aovs;
    // Key/value metadata written to the EXR header (docs/output.md has the list): "<key>" as
    // "nimbus:<key>", except OpenEXR's standard attributes "worldToCamera" and "worldToNDC".
    std::vector<std::pair<std::string, FilmValue>> metadata;
    // Deep pixels (output.deep), filled by the tile driver beside the AOVs; null: none.
    std::shared_ptr<DeepFilm> deep;

    Aov& add(const std::string& name, int channels, bool isData);
    Aov* find(const std::string& name);
    const Aov* find(const std::string& name) const;
    // The metadata value of `key`, or nullptr; set() replaces it or appends it.
    const FilmValue* meta(const std::string& key) const;
    void set(const std::string& key, FilmValue value);
    float* pixel(Aov& aov, int x, int y) { return aov.pixels.data() + (size_t(y) * width + x) * aov.channels; }
};

}  // namespace nimbus
