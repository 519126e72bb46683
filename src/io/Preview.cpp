#include "Preview.h"

#include "../core/DataFiles.h"

#include "AtomicFile.h"
#include "core/Error.h"
#include "render/Film.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <vector>

namespace OCIO = OCIO_NAMESPACE;

namespace nimbus {

namespace {

std::string oneLine(std::string text)
{
    std::replace(text.begin(), text.end(), '\n', ' ');
    while (!text.empty() && text.back() == ' ')
        text.pop_back();
    return text;
}

struct ConfigChoice {
    std::string path;
    std::string source;  // where the path came from, for the error message
};

ConfigChoice chooseConfig(const PreviewOptions& options)
{
    if (!options.config.empty())
        return {options.config, "preview options"};
    for (const char* variable : {"OCIO", "NIMBUS_OCIO_CONFIG"})
        if (const char* value = std::getenv(variable); value && *value)
            return {value, std::string("$") + variable};
    return {dataPath(DataFile::OcioConfig), "the shipped config"};
}

std::string listOf(const std::vector<std::string>& names)
{
    std::string list;
    for (const std::string& name : names)
        list += (list.empty() ? "'" : ", '") + name + "'";
    return list;
}

// A problem with the preview settings: the scene key it belongs to and what is wrong.
struct SettingError {
    std::string key;  // "output.preview", "output.preview_view", "output.preview_look"
    std::string message;
};

struct Resolved {
    OCIO::ConstConfigRcPtr config;
    std::string display, view, look;
    std::string where;  // "OCIO config '<path>' (<source>)"
};

// The config loaded and the display, view and look checked against it; throws SettingError.
Resolved resolve(const PreviewOptions& options)
{
    const ConfigChoice choice = chooseConfig(options);
    Resolved r;
    r.where = "OCIO config '" + choice.path + "' (" + choice.source + ")";
    try {
        r.config = OCIO::Config::CreateFromFile(choice.path.c_str());
        r.config->validate();
    } catch (const OCIO::Exception& e) {
        throw SettingError{"output.preview", "cannot load " + r.where + ": " + oneLine(e.what())};
    }

    r.display = options.display.empty() ? r.config->getDefaultDisplay() : options.display;
    std::vector<std::string> displays;
    for (int i = 0; i < r.config->getNumDisplays(); ++i)
        displays.push_back(r.config->getDisplay(i));
    if (std::find(displays.begin(), displays.end(), r.display) == displays.end())
        throw SettingError{"output.preview", "display '" + r.display + "' is not in " + r.where +
                                                 " (displays: " + listOf(displays) + ")"};
    r.view = options.view.empty() ? r.config->getDefaultView(r.display.c_str()) : options.view;
    std::vector<std::string> views;
    for (int i = 0; i < r.config->getNumViews(r.display.c_str()); ++i)
        views.push_back(r.config->getView(r.display.c_str(), i));
    if (std::find(views.begin(), views.end(), r.view) == views.end())
        throw SettingError{"output.preview_view", "'" + r.view + "' is not a view of display '" + r.display + "' in " +
                                                      r.where + " (views: " + listOf(views) + ")"};
    r.look = options.look;
    if (!r.look.empty()) {
        std::vector<std::string> looks;
        for (int i = 0; i < r.config->getNumLooks(); ++i)
            looks.push_back(r.config->getLookNameByIndex(i));
        if (std::find(looks.begin(), looks.end(), r.look) == looks.end())
            throw SettingError{"output.preview_look", "'" + r.look + "' is not a look in " + r.where + " (looks: " +
                                                          (looks.empty() ? std::string("none") : listOf(looks)) + ")"};
    }
    return r;
}

// The CPU processor from scene_linear through the look (when one is set, in place of the view's
// own looks) to the chosen display and view.
OCIO::ConstCPUProcessorRcPtr displayProcessor(const Resolved& r)
{
    try {
        OCIO::DisplayViewTransformRcPtr transform = OCIO::DisplayViewTransform::Create();
        transform->setSrc(OCIO::ROLE_SCENE_LINEAR);
        transform->setDisplay(r.display.c_str());
        transform->setView(r.view.c_str());
        if (r.look.empty())
            return r.config->getProcessor(transform)->getDefaultCPUProcessor();
        OCIO::LegacyViewingPipelineRcPtr pipeline = OCIO::LegacyViewingPipeline::Create();
        pipeline->setDisplayViewTransform(transform);
        pipeline->setLooksOverrideEnabled(true);
        pipeline->setLooksOverride(r.look.c_str());
        return pipeline->getProcessor(r.config)->getDefaultCPUProcessor();
    } catch (const OCIO::Exception& e) {
        throw Error("cannot build display '" + r.display + "', view '" + r.view + "'" +
                    (r.look.empty() ? std::string() : ", look '" + r.look + "'") + " from " + r.where + ": " +
                    oneLine(e.what()));
    }
}

}  // namespace

void checkPreviewSettings(const PreviewOptions& options, const std::string& where)
{
    try {
        displayProcessor(resolve(options));
    } catch (const SettingError& e) {
        throw InputError(where + ": " + e.key + ": " + e.message);
    } catch (const Error& e) {
        throw InputError(where + ": output.preview: " + e.what());
    }
}

void writePreview(const Film& film, const std::string& path, const PreviewOptions& options)
{
    auto fail = [&](const std::string& why) { return Error("cannot write preview '" + path + "': " + why); };
    const Aov* beauty = film.find("beauty");
    if (!beauty)
        throw fail("the film has no beauty AOV");
    if (film.width <= 0 || film.height <= 0)
        throw fail("the film is empty");
    if (beauty->pixels.size() != size_t(film.width) * film.height * beauty->channels ||
        (beauty->channels != 1 && beauty->channels != 3 && beauty->channels != 4))
        throw fail("the beauty AOV's buffer does not match the film");
    int x0 = film.x0, y0 = film.y0, x1 = film.x1, y1 = film.y1;
    if (x0 == 0 && y0 == 0 && x1 == 0 && y1 == 0) {
        x1 = film.width;
        y1 = film.height;
    }
    x0 = std::clamp(x0, 0, film.width);
    x1 = std::clamp(x1, x0, film.width);
    y0 = std::clamp(y0, 0, film.height);
    y1 = std::clamp(y1, y0, film.height);

    OCIO::ConstCPUProcessorRcPtr processor;
    try {
        processor = displayProcessor(resolve(options));
    } catch (const SettingError& e) {
        throw Error(e.message);
    }

    // Scene-linear RGB of the crop. NaN (a failed sample) shows black rather than whatever the
    // 8-bit conversion makes of it; +inf stays and clips to white.
    const int cropWidth = x1 - x0, cropHeight = y1 - y0;
    const float scale = std::exp2(options.exposure);
    std::vector<float> rgb(size_t(cropWidth) * cropHeight * 3);
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
            const float* src = beauty->pixels.data() + (size_t(y) * film.width + x) * beauty->channels;
            float* dst = rgb.data() + (size_t(y - y0) * cropWidth + (x - x0)) * 3;
            for (int c = 0; c < 3; ++c) {
                const float v = src[beauty->channels == 1 ? 0 : c] * scale;
                dst[c] = std::isnan(v) ? 0.0f : v;
            }
        }
    if (!rgb.empty()) {
        try {
            OCIO::PackedImageDesc image(rgb.data(), cropWidth, cropHeight, 3);
            processor->apply(image);
        } catch (const OCIO::Exception& e) {
            throw fail(oneLine(e.what()));
        }
    }

    // Full frame; the crop's display values clamped to [0, 1] and rounded to 8 bits.
    std::vector<unsigned char> pixels(size_t(film.width) * film.height * 3, 0);
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
            for (int c = 0; c < 3; ++c) {
                float v = rgb[(size_t(y - y0) * cropWidth + (x - x0)) * 3 + c];
                v = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
                pixels[(size_t(y) * film.width + x) * 3 + c] = static_cast<unsigned char>(std::lround(v * 255.0f));
            }

    OIIO::ImageSpec spec(film.width, film.height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    spec.attribute("Software", "nimbus " NIMBUS_VERSION);

    // By format name: the temporary file's name has no extension (AtomicFile.h). Every step's
    // result is checked (a full disk shows up at write_image or close): a failure throws before
    // commit, so the truncated temporary file is removed and never renamed over a good preview.
    AtomicFile file(path);
    // Through a stream AtomicFile owns, so that commit() sees every write error. Declared before
    // the writer, which may still write through it when destroyed on an error path.
    OIIO::Filesystem::IOFile proxy(file.stream(), OIIO::Filesystem::IOProxy::Write);
    std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("png");
    if (!out)
        throw fail(oneLine(OIIO::geterror()));
    out->set_ioproxy(&proxy);
    if (!out->open(file.tempPath(), spec))
        throw fail(oneLine(out->geterror()));
    if (!out->write_image(OIIO::TypeDesc::UINT8, pixels.data()))
        throw fail(oneLine(out->geterror()));
    if (!out->close())
        throw fail(oneLine(out->geterror()));
    out.reset();
    file.commit();
}

}  // namespace nimbus
