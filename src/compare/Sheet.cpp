// Sheet.cpp: writeSheet (Sheet.h), drawn with OpenImageIO.
#include "Sheet.h"
#include "FilmAccess.h"

#include "../core/Error.h"
#include "../io/Preview.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

namespace nimbus {

namespace fs = std::filesystem;

void writeSheet(const Film& ref, const Film& wkb, const Film& pt, const std::string& path, const std::string& tmpDir)
{
    const int w = ref.width, h = ref.height, n = w * h;
    Film strip;
    strip.width = 3 * w, strip.height = h, strip.x1 = 3 * w, strip.y1 = h;
    Aov& b = strip.add("beauty", 4, false);
    b.pixels.assign(size_t(strip.width) * size_t(h) * 4, 0.0f);
    const Film* panels[3] = {&ref, &wkb, &pt};
    for (int k = 0; k < 3; ++k) {
        const Aov& a = requireAov(*panels[k], "beauty");
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const float* p = a.pixels.data() + (size_t(y) * w + x) * size_t(a.channels);
                float* q = strip.pixel(b, k * w + x, y);
                q[0] = p[0], q[1] = p[1], q[2] = p[2], q[3] = 1.0f;
            }
    }
    const std::string tmp = tmpDir + "/.sheet-strip.png";
    writePreview(strip, tmp);
    OIIO::ImageBuf in(tmp);
    if (!in.read(0, 0, true, OIIO::TypeDesc::FLOAT))
        throw Error("compare: cannot read back " + tmp);
    const int Z = 4, pad = 4, sw = 4 * w * Z + 3 * pad;
    OIIO::ImageBuf sheet(OIIO::ImageSpec(sw, h * Z, 3, OIIO::TypeDesc::UINT8));
    auto put = [&](int panel, int x, int y, const float* c) {
        for (int j = 0; j < Z; ++j)
            for (int i = 0; i < Z; ++i)
                sheet.setpixel(panel * (w * Z + pad) + x * Z + i, y * Z + j, c, 3);
    };
    OIIO::ImageBufAlgo::fill(sheet, {0.5f, 0.5f, 0.5f});
    std::vector<float> px(3);
    for (int k = 0; k < 3; ++k)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                in.getpixel(k * w + x, y, px.data(), 3);
                put(k, x, y, px.data());
            }
    const Aov& ra = requireAov(ref, "beauty");
    const Aov& wa = requireAov(wkb, "beauty");
    float peak = 0;
    for (int i = 0; i < n; ++i)
        peak = std::max(peak, std::fabs(lum(wa, size_t(i)) - lum(ra, size_t(i))));
    const float scale = peak > 0 ? 1.0f / peak : 1.0f;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const size_t i = size_t(y) * w + x;
            const float d = std::clamp((lum(wa, i) - lum(ra, i)) * scale, -1.0f, 1.0f);
            float c[3] = {1 - std::max(-d, 0.0f), 1 - std::fabs(d), 1 - std::max(d, 0.0f)};
            put(3, x, y, c);
        }
    fs::remove(tmp);
    if (!sheet.write(path))
        throw Error("compare: cannot write " + path + ": " + sheet.geterror());
}

}  // namespace nimbus
