#include "ExrReader.h"

#include "../core/Error.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <memory>
#include <vector>

namespace nimbus {

namespace {

std::string oneLine(std::string text)
{
    std::replace(text.begin(), text.end(), '\n', ' ');
    while (!text.empty() && text.back() == ' ')
        text.pop_back();
    return text.empty() ? std::string("unknown OpenImageIO error") : text;
}

// A layer's channels: file channel indices in the AOV's component order.
struct Layer {
    std::string name;
    std::vector<std::string> suffixes;
    std::vector<int> channels;
    bool isData = false;
};

int componentOf(const std::string& suffix, size_t count)
{
    if (count == 1)
        return 0;
    static const char* const order[] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; ++c)
        if (suffix == order[c])
            return c;
    return -1;
}

}  // namespace

Film readExr(const std::string& path)
{
    auto fail = [&](const std::string& why) { return InputError("'" + path + "': " + why); };
    std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path);
    if (!in)
        throw fail("cannot read as OpenEXR: " + oneLine(OIIO::geterror()));
    const OIIO::ImageSpec& spec = in->spec();
    if (std::string(in->format_name()) != "openexr")
        throw fail("not an OpenEXR file (" + std::string(in->format_name()) + ")");
    if (spec.full_x != 0 || spec.full_y != 0 || spec.full_width <= 0 || spec.full_height <= 0 || spec.x < 0 ||
        spec.y < 0 || spec.x + spec.width > spec.full_width || spec.y + spec.height > spec.full_height ||
        spec.depth != 1)
        throw fail("its data window is not inside a display window starting at 0, 0");

    Film film;
    film.width = spec.full_width;
    film.height = spec.full_height;
    film.x0 = spec.x, film.x1 = spec.x + spec.width;
    film.y0 = spec.y, film.y1 = spec.y + spec.height;

    std::vector<Layer> layers;
    for (int c = 0; c < spec.nchannels; ++c) {
        const std::string& name = spec.channelnames[size_t(c)];
        const size_t dot = name.rfind('.');
        if (dot == std::string::npos)
            continue;  // the main layer: copies of beauty and depth
        const std::string layer = name.substr(0, dot);
        auto it = std::find_if(layers.begin(), layers.end(), [&](const Layer& l) { return l.name == layer; });
        if (it == layers.end()) {
            layers.push_back({layer, {}, {}, false});
            it = layers.end() - 1;
        }
        it->suffixes.push_back(name.substr(dot + 1));
        it->channels.push_back(c);
        it->isData = spec.channelformat(c) == OIIO::TypeDesc::FLOAT;
    }
    if (layers.empty())
        throw fail("no AOV layers (channels '<aov>.R' and so on): not written by nimbus");

    std::vector<float> pixels(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data()))
        throw fail("cannot read its pixels: " + oneLine(in->geterror()));

    for (const Layer& layer : layers) {
        const size_t count = layer.channels.size();
        if (count != 1 && count != 3 && count != 4)
            throw fail("layer '" + layer.name + "' has " + std::to_string(count) + " channels (1, 3 or 4 expected)");
        std::vector<int> component(count);
        for (size_t i = 0; i < count; ++i) {
            component[i] = componentOf(layer.suffixes[i], count);
            if (component[i] < 0 || component[i] >= int(count))
                throw fail("layer '" + layer.name + "' has an unexpected channel '" + layer.suffixes[i] + "'");
        }
        Aov& aov = film.add(layer.name, int(count), layer.isData);
        for (int y = film.y0; y < film.y1; ++y)
            for (int x = film.x0; x < film.x1; ++x) {
                const float* src = pixels.data() +
                                   (size_t(y - film.y0) * size_t(spec.width) + size_t(x - film.x0)) * spec.nchannels;
                float* dst = film.pixel(aov, x, y);
                for (size_t i = 0; i < count; ++i)
                    dst[component[i]] = src[layer.channels[i]];
            }
    }

    for (const OIIO::ParamValue& p : spec.extra_attribs) {
        std::string key = p.name().string();
        if (key == "worldtocamera" || key == "worldToCamera")
            key = "worldToCamera";
        else if (key == "worldtoNDC" || key == "worldToNDC")
            key = "worldToNDC";
        else if (key.rfind("nimbus:", 0) == 0)
            key = key.substr(7);
        else
            continue;
        const OIIO::TypeDesc t = p.type();
        if (t == OIIO::TypeDesc::STRING)
            film.set(key, std::string(p.get_string()));
        else if (t == OIIO::TypeDesc::INT)
            film.set(key, p.get_int());
        else if (t == OIIO::TypeDesc::DOUBLE)
            film.set(key, *static_cast<const double*>(p.data()));
        else if (t == OIIO::TypeDesc::FLOAT)
            film.set(key, double(*static_cast<const float*>(p.data())));
        else if (t == OIIO::TypeMatrix44) {
            Matrix44 m{};
            std::copy_n(static_cast<const float*>(p.data()), 16, m.data());
            film.set(key, m);
        }
    }
    return film;
}

}  // namespace nimbus
