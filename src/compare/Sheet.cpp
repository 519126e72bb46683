// Sheet.cpp: writeSheetPanels (Sheet.h). The panels are kept at the film's own resolution: the
// script magnifies them (nearest pixel) and adds what an image file cannot say, the titles and
// the difference's scale.
#include "Sheet.h"
#include "FilmAccess.h"

#include "../core/Error.h"
#include "../io/Preview.h"

#include <OpenImageIO/imagebuf.h>

#include <filesystem>

namespace nimbus {

namespace fs = std::filesystem;

void writeSheetPanels(const Film& ref, const Film& wkb, const Film& pt, const std::string& dir)
{
    const Aov& ra = requireAov(ref, "beauty");
    const Aov& wa = requireAov(wkb, "beauty");
    requireAov(pt, "beauty");
    for (const Film* f : {&wkb, &pt})
        if (f->width != ref.width || f->height != ref.height)
            throw Error("compare: the sheet's films differ in size");
    fs::create_directories(dir);
    writePreview(ref, dir + "/reference.png");
    writePreview(wkb, dir + "/wkb.png");
    writePreview(pt, dir + "/pathtrace.png");

    OIIO::ImageSpec spec(ref.width, ref.height, 1, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"Y"};
    OIIO::ImageBuf diff(spec);
    for (int y = 0; y < ref.height; ++y)
        for (int x = 0; x < ref.width; ++x) {
            const size_t i = size_t(y) * size_t(ref.width) + size_t(x);
            const float d = lum(wa, i) - lum(ra, i);
            diff.setpixel(x, y, &d, 1);
        }
    const std::string path = dir + "/difference.exr", tmp = dir + "/.difference.tmp.exr";
    if (!diff.write(tmp)) {
        fs::remove(tmp);
        throw Error("compare: cannot write " + path + ": " + diff.geterror());
    }
    fs::rename(tmp, path);
}

}  // namespace nimbus
