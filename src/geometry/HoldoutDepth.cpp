#include "HoldoutDepth.h"

#include "../core/Error.h"
#include "../core/Log.h"

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
    auto in = OIIO::ImageInput::open(spec.file);
    if (!in)
        throw InputError(fileKey + ": cannot read " + quoted + ": " + OIIO::geterror());
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
    // Pixel centres of this image at integers.
    const float fx = x * mScaleX - 0.5f, fy = y * mScaleY - 0.5f;
    auto at = [&](int ix, int iy) {
        ix = std::min(std::max(ix, 0), mWidth - 1);
        iy = std::min(std::max(iy, 0), mHeight - 1);
        return mDepth[size_t(iy) * size_t(mWidth) + size_t(ix)];
    };
    const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
    const float wx = fx - float(x0), wy = fy - float(y0);
    const float a = at(x0, y0), b = at(x0 + 1, y0), c = at(x0, y0 + 1), d = at(x0 + 1, y0 + 1);
    if (std::isfinite(a) && std::isfinite(b) && std::isfinite(c) && std::isfinite(d)) {
        const float top = a + wx * (b - a), bottom = c + wx * (d - c);
        return top + wy * (bottom - top);
    }
    return at(int(std::floor(x * mScaleX)), int(std::floor(y * mScaleY)));  // the pixel holding (x, y)
}

}  // namespace nimbus
