// EnvironmentMap.h: an environment light's HDR latitude-longitude map and its sampling
// distribution (kernels/shared/envmap.h has the orientation, the layout and the pdf), read
// through OpenImageIO once per render.
//
// The texels are the map's RGB as stored (scene-linear); the light's colour, radiance times
// intensity, multiplies them outside (NbLight.color). The distribution is built in double and
// stored in float: sampling and pdf read the same float CDFs, so the pdf is the sampler's
// exact density whatever the rounding.
#pragma once

#include "../scene/Scene.h"

#include "../../kernels/shared/envmap.h"

#include <memory>
#include <vector>

namespace nimbus {

class EnvironmentMap {
public:
    // From RGB texels, row-major from the top row (3 floats each); rotate in degrees about +y.
    // Negative or non-finite texels throw InputError naming `where`.
    EnvironmentMap(int width, int height, std::vector<float> rgb, float rotateDegrees,
                   const std::string& where = "environment map");

    // Reads scene.lights[light].map (an environment light's; InputError naming the file and the
    // key, lights[i].map, where it is missing or unreadable or holds negative or non-finite
    // values). Null where the light has no map.
    static std::shared_ptr<const EnvironmentMap> load(const Scene& scene, size_t light);

    NbEnvMap header() const { return mHeader; }
    const std::vector<float>& data() const { return mData; }  // envmap.h's layout
    int width() const { return mHeader.width; }
    int height() const { return mHeader.height; }

    Rgb texel(int i, int j) const
    {
        const float* t = mData.data() + 3 * (size_t(j) * size_t(mHeader.width) + size_t(i));
        return make_float3(t[0], t[1], t[2]);
    }
    Rgb lookup(float3 w) const { return nbEnvLookup(mHeader, mData.data(), w); }
    float pdf(float3 w) const { return nbEnvPdf(mHeader, mData.data(), w); }
    float3 sample(float u0, float u1, float& pdf) const { return nbEnvSample(mHeader, mData.data(), u0, u1, &pdf); }

    // The solid angle of a texel of row j, 2 pi / W (cos theta_j - cos theta_{j+1}), steradians.
    double texelSolidAngle(int j) const;
    // The world direction at the centre of texel (i, j).
    float3 texelDirection(int i, int j) const;
    // The map's integral over the sphere, int map dOmega (W/(m^2) per unit colour).
    Rgb integral() const;

private:
    NbEnvMap mHeader{};
    std::vector<float> mData;
};

}  // namespace nimbus
