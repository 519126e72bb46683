#include "HoldoutDepth.h"

#include "../core/Error.h"
#include "../core/Log.h"
#include "../core/MemoryLimit.h"
#include "../core/OpenImageFile.h"

#include "../../kernels/shared/holdoutdepth.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <system_error>

namespace nimbus {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

}  // namespace

HoldoutDepth::HoldoutDepth(int width, int height, std::vector<float> depth, int cameraWidth, int cameraHeight)
    : mWidth(width), mHeight(height), mDepth(std::move(depth))
{
    mScaleX = float(width) / float(cameraWidth);
    mScaleY = float(height) / float(cameraHeight);
    for (float& z : mDepth)
        if (z == 0.0f)
            z = kInf;  // "0 or infinity: no holdout"
}

std::unique_ptr<HoldoutDepth> HoldoutDepth::load(const Scene& scene)
{
    const HoldoutDepthFile& spec = scene.camera.holdoutDepth;
    if (spec.file.empty())
        return nullptr;
    const std::string where = (scene.sourcePath.empty() ? std::string("scene") : scene.sourcePath) + ": ";
    const std::string fileKey = where + "camera.holdout_depth.file";
    const std::string quoted = "'" + spec.file + "'";
    std::error_code ec;
    if (!std::filesystem::exists(spec.file, ec))
        throw InputError(fileKey + ": cannot open " + quoted + ": no such file");
    // Every check before a pixel is allocated: the depth channel read (a float a pixel) and the
    // map kept (another).
    std::string problem;
    auto in = openCheckedImage(spec.file, [](int) { return 8.0; },
                               memoryLimitBytes(double(scene.render.memoryLimit)), problem);
    if (!in)
        throw InputError(fileKey + ": cannot read " + quoted + ": " + problem);
    const OIIO::ImageSpec& is = in->spec();
    int channel = -1;
    std::string names;
    for (int c = 0; c < is.nchannels; ++c) {
        const std::string name = is.channel_name(c);
        names += (names.empty() ? "" : ", ") + name;
        if (name == spec.channel)
            channel = c;
    }
    if (channel < 0)
        throw InputError(where + "camera.holdout_depth.channel: no channel '" + spec.channel + "' in " + quoted +
                         " (channels: " + names + ")");
    const int w = is.width, h = is.height, cw = scene.camera.width, ch = scene.camera.height;
    if (w != cw || h != ch) {
        // Same aspect within half a pixel of the larger image: a proxy or a higher-resolution
        // render of the same frame.
        const double aspectError = std::fabs(double(w) / h - double(cw) / ch);
        if (!(aspectError * std::max(h, ch) <= 0.5))
            throw InputError(fileKey + ": " + quoted + " is " + std::to_string(w) + "x" + std::to_string(h) +
                             ", the camera renders " + std::to_string(cw) + "x" + std::to_string(ch) +
                             " (another aspect ratio; give a depth image of the camera's resolution)");
        logWarning(fileKey + ": " + quoted + " is " + std::to_string(w) + "x" + std::to_string(h) +
                   ", resampled to the camera's " + std::to_string(cw) + "x" + std::to_string(ch));
    }
    std::vector<float> depth(size_t(w) * size_t(h));
    if (!in->read_image(0, 0, channel, channel + 1, OIIO::TypeDesc::FLOAT, depth.data()))
        throw InputError(fileKey + ": cannot read " + quoted + ": " + in->geterror());
    in->close();
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float z = depth[size_t(y) * w + x];
            if (std::isnan(z) || z < 0.0f)
                throw InputError(fileKey + ": " + quoted + ": pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                 ") has depth " + std::to_string(z) +
                                 " (expected a distance >= 0 along the view axis; 0 or inf for none)");
        }
    return std::make_unique<HoldoutDepth>(w, h, std::move(depth), cw, ch);
}

float HoldoutDepth::depthAt(float x, float y) const
{
    return nbHoldoutDepthAt(mDepth.data(), mWidth, mHeight, mScaleX, mScaleY, x, y);
}

}  // namespace nimbus
