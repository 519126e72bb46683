// DefaultScene.cpp: the picture a newcomer should see first (issue 13, item 5): a bright cumulus
// under a sun and a sky, rendered with multiple scattering (`wkb`), in about a minute on two
// cores. The cloud is thick enough to self-shadow, the sun sculpts it and the sky, an
// environment light read from its grid (docs/single-scattering.md), fills its shadowed side.
#include "DefaultScene.h"

namespace nimbus {

Scene defaultScene()
{
    Scene s;

    // Vertical fov 40 degrees at 8.6 m: the frame is 6.3 m tall, so a 4 m wide cloud fills
    // about two thirds of its height with room for the wisps the generator adds.
    s.camera.from = make_float3(0.0f, 1.2f, 8.5f);
    s.camera.to = make_float3(0.0f, 0.0f, 0.0f);
    s.camera.up = make_float3(0.0f, 1.0f, 0.0f);
    s.camera.fov = 40.0f;
    s.camera.width = 640;
    s.camera.height = 360;

    // Key: late-afternoon sun, from the upper left front, a little warm (3 W/m^2 on average).
    Light key;
    key.name = "key";
    key.type = LightType::Distant;
    key.direction = make_float3(1.0f, -1.0f, -0.7f);  // direction of travel, any length
    key.irradiance = make_float3(3.2f, 3.0f, 2.7f);
    key.angle = 0.53f;  // the sun's apparent diameter
    s.lights.push_back(key);

    // Sky: a uniform blue environment, which is also what the camera sees behind the cloud. Its
    // irradiance on a level surface, pi L, is about 0.53 W/m^2: a sixth of the sun's, as for a
    // clear afternoon sky.
    Light sky;
    sky.name = "sky";
    sky.type = LightType::Environment;
    sky.radiance = make_float3(0.06f, 0.13f, 0.32f);
    s.lights.push_back(sky);

    // The generator's default parameters give a cloud of about 2 m radius centred at the origin.
    Volume cloud;
    cloud.name = "cloud";
    cloud.source.type = SourceType::Procedural;
    cloud.source.generator = "cloud";
    // Optical depth about 10 through the centre at density 1: thick enough for the key light
    // to shadow the far side, thin enough that single scattering still reads as a cloud.
    cloud.medium.sigma_s = splat(2.5f);
    cloud.medium.sigma_a = splat(0.025f);           // albedo 0.99, as for water droplets
    cloud.medium.phase = {0.6f, 0.0f, 0.0f, 0.0f};  // forward scattering, a silver lining
    s.volumes.push_back(cloud);

    s.render.method = Method::Wkb;
    s.output.file = "out/default.exr";
    s.output.preview = "out/default.png";
    return s;
}

}  // namespace nimbus
