#include "ExrWriter.h"

#include "AtomicFile.h"
#include "core/Error.h"
#include "core/Log.h"
#include "render/Film.h"

#include <Imath/half.h>
#include <OpenImageIO/deepdata.h>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <set>
#include <variant>
#include <vector>

namespace nimbus {

namespace {

// One channel of the file: where its values come from in the Film.
struct ChannelSource {
    std::string name;
    const Aov* aov = nullptr;  // nullptr: the constant 1 (plain A when there is no alpha)
    int component = 0;
    OIIO::TypeDesc type;
};

// OpenImageIO error text can span lines; the CLI prints one line per error.
std::string oneLine(std::string text)
{
    std::replace(text.begin(), text.end(), '\n', ' ');
    while (!text.empty() && text.back() == ' ')
        text.pop_back();
    return text.empty() ? std::string("unknown OpenImageIO error") : text;
}

constexpr float kHalfMax = 65504.0f;

// OpenEXR's channel names by meaning: A alpha, Z depth, Y any other scalar (variance).
const char* singleChannelName(const std::string& aov)
{
    if (aov == "alpha")
        return "A";
    if (aov == "depth")
        return "Z";
    return "Y";
}

OIIO::TypeDesc typeOf(const Aov& aov)
{
    return aov.isData ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::HALF;
}

std::vector<ChannelSource> channelLayout(const Film& film, const std::string& path)
{
    auto fail = [&](const std::string& why) { return Error("cannot write EXR '" + path + "': " + why); };
    const size_t pixels = size_t(film.width) * film.height;
    for (const Aov& aov : film.aovs) {
        if (aov.name.empty() || aov.name.find('.') != std::string::npos)
            throw fail("AOV name '" + aov.name + "' is empty or contains '.', the layer separator");
        if (aov.channels != 1 && aov.channels != 3 && aov.channels != 4)
            throw fail("AOV '" + aov.name + "' has " + std::to_string(aov.channels) + " channels (1, 3 or 4 expected)");
        if (aov.pixels.size() != pixels * aov.channels)
            throw fail("AOV '" + aov.name + "' holds " + std::to_string(aov.pixels.size()) + " values, not " +
                       std::to_string(pixels * aov.channels) + " for a " + std::to_string(film.width) + "x" +
                       std::to_string(film.height) + " film");
    }

    std::vector<ChannelSource> channels;
    // The main layer compositors read by default: the beauty's R, G, B, A (its alpha is the
    // beauty's own when it has one, so that A and beauty.A agree, else the alpha AOV, else
    // opaque) and Z, the depth AOV, when the film has one.
    if (const Aov* beauty = film.find("beauty")) {
        static const char* const rgb[] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c)
            channels.push_back({rgb[c], beauty, beauty->channels == 1 ? 0 : c, OIIO::TypeDesc::HALF});
        if (beauty->channels == 4)
            channels.push_back({"A", beauty, 3, OIIO::TypeDesc::HALF});
        else if (const Aov* alpha = film.find("alpha"); alpha && alpha->channels == 1)
            channels.push_back({"A", alpha, 0, OIIO::TypeDesc::HALF});
        else
            channels.push_back({"A", nullptr, 0, OIIO::TypeDesc::HALF});
    }
    if (const Aov* depth = film.find("depth"); depth && depth->channels == 1)
        channels.push_back({"Z", depth, 0, OIIO::TypeDesc::FLOAT});
    // Every AOV as a layer of its own: colour as <aov>.R/.G/.B(.A); a 1-channel AOV as the one
    // channel its meaning names (singleChannelName).
    for (const Aov& aov : film.aovs) {
        if (aov.channels == 1) {
            channels.push_back({aov.name + "." + singleChannelName(aov.name), &aov, 0, typeOf(aov)});
            continue;
        }
        static const char* const suffixes[] = {".R", ".G", ".B", ".A"};
        for (int c = 0; c < aov.channels; ++c)
            channels.push_back({aov.name + suffixes[c], &aov, c, typeOf(aov)});
    }
    std::set<std::string> names;
    for (const ChannelSource& channel : channels)
        if (!names.insert(channel.name).second)
            throw fail("two AOVs both write channel '" + channel.name + "'");
    return channels;
}

// The film's metadata as header attributes (docs/output.md "Metadata"), with Software.
void addMetadata(OIIO::ImageSpec& spec, const Film& film)
{
    spec.attribute("Software", "nimbus " NIMBUS_VERSION);
    bool hasVersion = false;
    for (const auto& [key, value] : film.metadata) {
        std::string name = key.rfind("nimbus:", 0) == 0 ? key : "nimbus:" + key;
        // OpenEXR's standard camera attributes, by the names OpenImageIO maps to them.
        if (key == "worldToCamera")
            name = "worldtocamera";
        else if (key == "worldToNDC")
            name = "worldtoNDC";
        hasVersion = hasVersion || name == "nimbus:version";
        if (const std::string* text = std::get_if<std::string>(&value))
            spec.attribute(name, *text);
        else if (const int* integer = std::get_if<int>(&value))
            spec.attribute(name, *integer);
        else if (const double* real = std::get_if<double>(&value))
            spec.attribute(name, OIIO::TypeDesc::DOUBLE, real);
        else
            spec.attribute(name, OIIO::TypeMatrix44, std::get<Matrix44>(value).data());
    }
    if (!hasVersion)
        spec.attribute("nimbus:version", NIMBUS_VERSION);
}

// The data window: the film's crop, all zeros meaning the full frame. Throws `fail`'s error when
// it is empty or outside the frame.
template <class Fail>
void dataWindow(const Film& film, Fail fail, int& x0, int& y0, int& x1, int& y1)
{
    if (film.width <= 0 || film.height <= 0)
        throw fail("the film is empty (" + std::to_string(film.width) + "x" + std::to_string(film.height) + ")");
    x0 = film.x0, y0 = film.y0, x1 = film.x1, y1 = film.y1;
    if (x0 == 0 && y0 == 0 && x1 == 0 && y1 == 0) {
        x1 = film.width;
        y1 = film.height;
    }
    if (x0 < 0 || y0 < 0 || x1 > film.width || y1 > film.height || x0 >= x1 || y0 >= y1)
        throw fail("crop [" + std::to_string(x0) + "," + std::to_string(x1) + ") x [" + std::to_string(y0) + "," +
                   std::to_string(y1) + ") is empty or outside the " + std::to_string(film.width) + "x" +
                   std::to_string(film.height) + " frame");
}

}  // namespace

void writeExr(const Film& film, const std::string& path)
{
    auto fail = [&](const std::string& why) { return Error("cannot write EXR '" + path + "': " + why); };
    int x0, y0, x1, y1;
    dataWindow(film, fail, x0, y0, x1, y1);
    const std::vector<ChannelSource> channels = channelLayout(film, path);
    if (channels.empty())
        throw fail("the film has no AOVs");

    const int cropWidth = x1 - x0, cropHeight = y1 - y0;
    const int channelCount = int(channels.size());
    OIIO::ImageSpec spec(cropWidth, cropHeight, channelCount, OIIO::TypeDesc::HALF);
    spec.x = x0;
    spec.y = y0;
    spec.full_x = 0;
    spec.full_y = 0;
    spec.full_width = film.width;
    spec.full_height = film.height;
    spec.channelnames.clear();
    spec.channelformats.clear();
    for (const ChannelSource& channel : channels) {
        spec.channelnames.push_back(channel.name);
        spec.channelformats.push_back(channel.type);
    }
    // OpenImageIO only guesses alpha from a channel named "A"; layer alphas are not premultiplying.
    spec.alpha_channel = -1;
    for (int c = 0; c < channelCount; ++c)
        if (spec.channelnames[c] == "A")
            spec.alpha_channel = c;
    spec.z_channel = -1;
    for (int c = 0; c < channelCount; ++c)
        if (spec.channelnames[c] == "Z")
            spec.z_channel = c;
    spec.attribute("compression", "zip");
    addMetadata(spec, film);

    // By format name: the temporary file's name has no extension (AtomicFile.h).
    AtomicFile file(path);
    // Through a stream AtomicFile owns, so that commit() sees every write error. Declared before
    // the writer, which may still write through it when destroyed on an error path.
    OIIO::Filesystem::IOFile proxy(file.stream(), OIIO::Filesystem::IOProxy::Write);
    std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("openexr");
    if (!out)
        throw fail(oneLine(OIIO::geterror()));
    out->set_ioproxy(&proxy);
    if (!out->open(file.tempPath(), spec))
        throw fail(oneLine(out->geterror()));

    // Blocks of 16 scanlines, the OpenEXR zip block, so memory stays at a few rows however large
    // the frame. Pixels are packed in the file's own per-channel formats (half or float), so
    // OpenImageIO copies them as they are instead of converting value by value.
    size_t pixelBytes = 0;
    for (const ChannelSource& channel : channels)
        pixelBytes += channel.type.size();
    constexpr int rowsPerBlock = 16;
    std::vector<unsigned char> block(size_t(rowsPerBlock) * cropWidth * pixelBytes);
    // Half holds up to 65504; a larger finite value would become inf in the file. It is written
    // as +-65504 instead, and the pixels this happened to are counted per AOV for one warning.
    std::vector<std::pair<const Aov*, size_t>> clipped;  // AOV, pixels
    std::vector<const Aov*> clippedHere;                 // the AOVs clipped in this pixel
    for (int yBegin = y0; yBegin < y1; yBegin += rowsPerBlock) {
        const int yEnd = std::min(y1, yBegin + rowsPerBlock);
        unsigned char* dst = block.data();
        for (int y = yBegin; y < yEnd; ++y)
            for (int x = x0; x < x1; ++x) {
                clippedHere.clear();
                for (const ChannelSource& channel : channels) {
                    const size_t index = size_t(y) * film.width + x;
                    float v =
                        channel.aov ? channel.aov->pixels[index * channel.aov->channels + channel.component] : 1.0f;
                    if (channel.type == OIIO::TypeDesc::HALF) {
                        if (std::fabs(v) > kHalfMax && std::isfinite(v)) {
                            v = std::copysign(kHalfMax, v);
                            if (std::find(clippedHere.begin(), clippedHere.end(), channel.aov) == clippedHere.end()) {
                                clippedHere.push_back(channel.aov);
                                auto it = std::find_if(clipped.begin(), clipped.end(),
                                                       [&](const auto& c) { return c.first == channel.aov; });
                                if (it == clipped.end())
                                    clipped.push_back({channel.aov, 1});
                                else
                                    ++it->second;
                            }
                        }
                        const Imath::half h(v);
                        std::memcpy(dst, &h, sizeof h);
                        dst += sizeof h;
                    } else {
                        std::memcpy(dst, &v, sizeof v);
                        dst += sizeof v;
                    }
                }
            }
        if (!out->write_scanlines(yBegin, yEnd, 0, OIIO::TypeDesc::UNKNOWN, block.data()))
            throw fail(oneLine(out->geterror()));
    }
    if (!out->close())
        throw fail(oneLine(out->geterror()));
    out.reset();
    file.commit();
    if (!clipped.empty()) {
        std::string list;
        for (const auto& [aov, pixels] : clipped)
            list += (list.empty() ? "" : ", ") + aov->name + " (" + std::to_string(pixels) + " pixels)";
        logWarning("EXR '" + path + "': values above 65504, the largest half, written as 65504 in " + list);
    }
}

void writeDeepExr(const Film& film, const std::string& path)
{
    auto fail = [&](const std::string& why) { return Error("cannot write deep EXR '" + path + "': " + why); };
    if (!film.deep)
        throw fail("the film has no deep pixels");
    const DeepFilm& deep = *film.deep;
    int x0, y0, x1, y1;
    dataWindow(film, fail, x0, y0, x1, y1);
    if (deep.width != film.width || deep.height != film.height ||
        deep.pixels.size() != size_t(film.width) * size_t(film.height))
        throw fail("the deep pixels are not the film's size");

    // OpenEXR's deep channels: premultiplied R, G, B, A and the sample's depth interval Z, ZBack,
    // all float (deep compositing sums many small values; half would lose them).
    const int cropWidth = x1 - x0, cropHeight = y1 - y0;
    OIIO::ImageSpec spec(cropWidth, cropHeight, 6, OIIO::TypeDesc::FLOAT);
    spec.x = x0;
    spec.y = y0;
    spec.full_x = 0;
    spec.full_y = 0;
    spec.full_width = film.width;
    spec.full_height = film.height;
    spec.deep = true;
    spec.channelnames = {"R", "G", "B", "A", "Z", "ZBack"};
    spec.alpha_channel = 3;
    spec.z_channel = 4;
    spec.attribute("compression", "zips");  // deep scanlines allow none, rle, zips
    addMetadata(spec, film);
    spec.attribute("nimbus:deep_samples", deep.maxSamples);

    OIIO::DeepData data;
    data.init(spec);
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
            data.set_samples(int64_t(y - y0) * cropWidth + (x - x0), int(deep.at(x, y).size()));
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
            const int64_t pixel = int64_t(y - y0) * cropWidth + (x - x0);
            const std::vector<DeepSample>& samples = deep.at(x, y);
            for (size_t k = 0; k < samples.size(); ++k) {
                const DeepSample& s = samples[k];
                const float values[6] = {s.color.x, s.color.y, s.color.z, s.alpha, s.z, s.zBack};
                for (int c = 0; c < 6; ++c)
                    data.set_deep_value(pixel, c, int(k), values[c]);
            }
        }

    AtomicFile file(path);
    OIIO::Filesystem::IOFile proxy(file.stream(), OIIO::Filesystem::IOProxy::Write);
    std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("openexr");
    if (!out)
        throw fail(oneLine(OIIO::geterror()));
    if (!out->supports("deepdata"))
        throw fail("this OpenImageIO's OpenEXR writer has no deep data");
    out->set_ioproxy(&proxy);
    if (!out->open(file.tempPath(), spec))
        throw fail(oneLine(out->geterror()));
    if (!out->write_deep_image(data))
        throw fail(oneLine(out->geterror()));
    if (!out->close())
        throw fail(oneLine(out->geterror()));
    out.reset();
    file.commit();
}

}  // namespace nimbus
