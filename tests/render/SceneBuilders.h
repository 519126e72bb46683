// SceneBuilders.h: small scenes with known answers, built through the public Scene API.
#pragma once

#include "scene/Scene.h"

#include <string>

namespace nimbus::test {

// A homogeneous box of the given size (metres), centred at the origin, density 1.
inline Volume homogeneousBox(float sx, float sy, float sz, float voxel, Rgb sigma_s, Rgb sigma_a, float g = 0.0f)
{
    Volume v;
    v.name = "box";
    v.source.type = SourceType::Procedural;
    v.source.generator = "box";
    v.source.params = {{"size_x", sx}, {"size_y", sy}, {"size_z", sz}, {"voxel_size", voxel}, {"density", 1.0}};
    v.medium.sigma_s = sigma_s;
    v.medium.sigma_a = sigma_a;
    v.medium.phase = NbPhase{g, 0, 0, 0};
    return v;
}

// nimbus's procedural cumulus-like cloud (about 2 m across) at the given voxel size (metres).
inline Volume proceduralCloud(double voxel, Rgb sigma_s, Rgb sigma_a, float g)
{
    Volume v;
    v.name = "cloud";
    v.source.type = SourceType::Procedural;
    v.source.generator = "cloud";
    v.source.params = {{"voxel_size", voxel}};
    v.medium.sigma_s = sigma_s;
    v.medium.sigma_a = sigma_a;
    v.medium.phase = NbPhase{g, 0, 0, 0};
    return v;
}

// A distant light (a sun): direction of travel, irradiance in W/m^2.
inline Light distantLight(const std::string& name, float3 direction, Rgb irradiance)
{
    Light l;
    l.name = name;
    l.type = LightType::Distant;
    l.direction = normalize(direction);
    l.irradiance = irradiance;
    return l;
}

// A point light: position, radiant intensity in W/sr.
inline Light pointLight(const std::string& name, float3 position, Rgb intensity)
{
    Light l;
    l.name = name;
    l.type = LightType::Point;
    l.position = position;
    l.intensity = intensity;
    return l;
}

// A uniform environment light (a sky): radiance in W/(m^2 sr).
inline Light uniformSky(const std::string& name, Rgb radiance)
{
    Light l;
    l.name = name;
    l.type = LightType::Environment;
    l.radiance = radiance;
    return l;
}

// Analytic tests compare pixels with closed forms along their rays: a one-pixel box keeps every
// sample inside its pixel (the filters themselves: tests/engine/test_pixel_filter.cpp).
inline Scene emptyScene(int w, int h)
{
    Scene s;
    s.camera.width = w;
    s.camera.height = h;
    s.render.pixelFilter = PixelFilter::Box;
    s.render.filterWidth = 1.0f;
    s.render.threads = 0;
    s.output.file = "unused.exr";
    return s;
}

}  // namespace nimbus::test
