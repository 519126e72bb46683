#include "EnvironmentMap.h"

#include "../core/Error.h"
#include "../core/MemoryLimit.h"
#include "../core/OpenImageFile.h"

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <system_error>

namespace nimbus {

EnvironmentMap::EnvironmentMap(int width, int height, std::vector<float> rgb, float rotateDegrees,
                               const std::string& where)
{
    if (width < 1 || height < 1 || rgb.size() != size_t(width) * size_t(height) * 3)
        throw InputError(where + ": an environment map needs at least one texel of three channels");
    mHeader.width = width;
    mHeader.height = height;
    mHeader.rotate = float(double(rotateDegrees) * M_PI / 180.0);
    for (size_t k = 0; k < rgb.size(); ++k)
        if (!std::isfinite(rgb[k]) || rgb[k] < 0.0f) {
            const size_t t = k / 3;
            throw InputError(where + ": texel (" + std::to_string(t % size_t(width)) + ", " +
                             std::to_string(t / size_t(width)) + ") has value " + std::to_string(rgb[k]) +
                             " (expected finite radiance >= 0)");
        }
    mData = std::move(rgb);
    mData.resize(size_t(nbEnvDataSize(mHeader)));
    // pbrt-v4 sec. A.5.3: conditional CDFs per row, the marginal over the rows' sums, each
    // weighted by sin(theta) at the row's centre (the lat-long map's solid angle per texel).
    const size_t W = size_t(width), H = size_t(height);
    std::vector<double> rowSum(H, 0.0);
    std::vector<double> f(W);
    for (size_t j = 0; j < H; ++j) {
        const double s = std::sin(M_PI * (double(j) + 0.5) / double(H));
        double acc = 0.0;
        for (size_t i = 0; i < W; ++i) {
            const float* t = mData.data() + 3 * (j * W + i);
            f[i] = (double(t[0]) + double(t[1]) + double(t[2])) / 3.0 * s;
            acc += f[i];
        }
        rowSum[j] = acc;
        float* cdf = mData.data() + nbEnvConditionalOffset(mHeader, int(j));
        double run = 0.0;
        cdf[0] = 0.0f;
        for (size_t i = 0; i < W; ++i) {
            run += f[i];
            // A row of zeros: uniform (its marginal probability is 0, so it is never chosen).
            cdf[i + 1] = acc > 0.0 ? float(run / acc) : float(double(i + 1) / double(W));
        }
        cdf[W] = 1.0f;
    }
    double total = 0.0;
    for (double r : rowSum)
        total += r;
    float* marginal = mData.data() + nbEnvMarginalOffset(mHeader);
    double run = 0.0;
    marginal[0] = 0.0f;
    for (size_t j = 0; j < H; ++j) {
        run += rowSum[j];
        marginal[j + 1] = total > 0.0 ? float(run / total) : float(double(j + 1) / double(H));
    }
    marginal[H] = 1.0f;
}

std::shared_ptr<const EnvironmentMap> EnvironmentMap::load(const Scene& scene, size_t light)
{
    const Light& l = scene.lights[light];
    if (l.type != LightType::Environment || l.map.empty())
        return nullptr;
    const std::string where = (scene.sourcePath.empty() ? std::string("scene") : scene.sourcePath) + ": lights[" +
                              std::to_string(light) + "].map";
    const std::string quoted = "'" + l.map + "'";
    std::error_code ec;
    if (!std::filesystem::is_regular_file(l.map, ec))
        throw InputError(where + ": cannot open " + quoted + ": no such file");
    // Every check before a pixel is allocated: the reading buffer (nc floats a pixel), the RGB
    // copy (3) and the map with its sampling CDFs (4) are held at once.
    std::string problem;
    auto in = openCheckedImage(l.map, [](int nc) { return 4.0 * (nc + 3 + 4); },
                               memoryLimitBytes(double(scene.render.memoryLimit)), problem);
    if (!in)
        throw InputError(where + ": cannot read " + quoted + ": " + problem);
    const OIIO::ImageSpec& is = in->spec();
    const int w = is.width, h = is.height, nc = is.nchannels;
    std::vector<float> pixels(size_t(w) * size_t(h) * size_t(nc));
    if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, pixels.data()))
        throw InputError(where + ": cannot read " + quoted + ": " + in->geterror());
    in->close();
    // Grey images (one or two channels: Y, or Y and A) light in grey; RGB(A) as RGB.
    std::vector<float> rgb(size_t(w) * size_t(h) * 3);
    for (size_t p = 0; p < size_t(w) * size_t(h); ++p)
        for (int c = 0; c < 3; ++c)
            rgb[3 * p + size_t(c)] = pixels[p * size_t(nc) + size_t(nc >= 3 ? c : 0)];
    return std::make_shared<const EnvironmentMap>(w, h, std::move(rgb), l.rotate, where + ": " + quoted);
}

double EnvironmentMap::texelSolidAngle(int j) const
{
    const double H = mHeader.height;
    return 2.0 * M_PI / double(mHeader.width) * (std::cos(M_PI * j / H) - std::cos(M_PI * (j + 1) / H));
}

float3 EnvironmentMap::texelDirection(int i, int j) const
{
    return nbEnvDirection(mHeader, (float(i) + 0.5f) / float(mHeader.width), (float(j) + 0.5f) / float(mHeader.height));
}

Rgb EnvironmentMap::integral() const
{
    double acc[3] = {0, 0, 0};
    for (int j = 0; j < mHeader.height; ++j) {
        const double dOmega = texelSolidAngle(j);
        for (int i = 0; i < mHeader.width; ++i) {
            const Rgb t = texel(i, j);
            acc[0] += t.x * dOmega, acc[1] += t.y * dOmega, acc[2] += t.z * dOmega;
        }
    }
    return make_float3(float(acc[0]), float(acc[1]), float(acc[2]));
}

}  // namespace nimbus
