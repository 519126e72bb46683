// SceneCompare.h: field-by-field equality of two Scenes, for the JSON round-trip tests. Each
// field is its own EXPECT so that a failure names the field that did not survive.
#pragma once

#include "scene/Scene.h"

#include <gtest/gtest.h>

#include <string>

namespace nimbus::test {

inline void expectVecEq(float3 a, float3 b, const std::string& what)
{
    EXPECT_EQ(a.x, b.x) << what << ".x";
    EXPECT_EQ(a.y, b.y) << what << ".y";
    EXPECT_EQ(a.z, b.z) << what << ".z";
}

inline void expectCameraEq(const Camera& a, const Camera& b)
{
    expectVecEq(a.from, b.from, "camera.from");
    expectVecEq(a.to, b.to, "camera.to");
    expectVecEq(a.up, b.up, "camera.up");
    EXPECT_EQ(a.fov, b.fov);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    for (int i = 0; i < 4; ++i)
        EXPECT_EQ(a.crop[i], b.crop[i]) << "camera.crop[" << i << "]";
    EXPECT_EQ(a.shutterOpen, b.shutterOpen);
    EXPECT_EQ(a.shutterClose, b.shutterClose);
    EXPECT_EQ(a.hasMotion, b.hasMotion);
    expectVecEq(a.fromClose, b.fromClose, "camera.motion.from");
    expectVecEq(a.toClose, b.toClose, "camera.motion.to");
    expectVecEq(a.upClose, b.upClose, "camera.motion.up");
}

inline void expectLightEq(const Light& a, const Light& b, const std::string& w)
{
    EXPECT_EQ(a.name, b.name) << w;
    EXPECT_EQ(a.type, b.type) << w;
    expectVecEq(a.direction, b.direction, w + ".direction");
    expectVecEq(a.irradiance, b.irradiance, w + ".irradiance");
    EXPECT_EQ(a.angle, b.angle) << w;
    expectVecEq(a.position, b.position, w + ".position");
    expectVecEq(a.intensity, b.intensity, w + ".intensity");
    EXPECT_EQ(a.coneAngle, b.coneAngle) << w;
    EXPECT_EQ(a.coneSoftness, b.coneSoftness) << w;
    expectVecEq(a.center, b.center, w + ".center");
    expectVecEq(a.normal, b.normal, w + ".normal");
    expectVecEq(a.up, b.up, w + ".up");
    EXPECT_EQ(a.size[0], b.size[0]) << w;
    EXPECT_EQ(a.size[1], b.size[1]) << w;
    expectVecEq(a.radiance, b.radiance, w + ".radiance");
    EXPECT_EQ(a.radius, b.radius) << w;
    EXPECT_EQ(a.map, b.map) << w;
    EXPECT_EQ(a.rotate, b.rotate) << w;
    EXPECT_EQ(a.mapIntensity, b.mapIntensity) << w;
}

inline void expectVolumeEq(const Volume& a, const Volume& b, const std::string& w)
{
    EXPECT_EQ(a.name, b.name) << w;
    EXPECT_EQ(a.source.type, b.source.type) << w;
    EXPECT_EQ(a.source.file, b.source.file) << w;
    EXPECT_EQ(a.source.grids, b.source.grids) << w;
    EXPECT_EQ(a.source.generator, b.source.generator) << w;
    EXPECT_EQ(a.source.params, b.source.params) << w;
    EXPECT_EQ(a.source.pluginPath, b.source.pluginPath) << w;
    EXPECT_EQ(a.source.pluginParams, b.source.pluginParams) << w;
    EXPECT_EQ(a.transform.rowMajor(), b.transform.rowMajor()) << w;
    expectVecEq(a.medium.sigma_s, b.medium.sigma_s, w + ".medium.sigma_s");
    expectVecEq(a.medium.sigma_a, b.medium.sigma_a, w + ".medium.sigma_a");
    EXPECT_EQ(a.medium.densityScale, b.medium.densityScale) << w;
    EXPECT_EQ(a.medium.phase.g, b.medium.phase.g) << w;
    EXPECT_EQ(a.medium.phase.g2, b.medium.phase.g2) << w;
    EXPECT_EQ(a.medium.phase.blend, b.medium.phase.blend) << w;
    EXPECT_EQ(a.medium.emissionScale, b.medium.emissionScale) << w;
    EXPECT_EQ(a.shader, b.shader) << w;
}

inline void expectSceneEq(const Scene& a, const Scene& b)
{
    expectCameraEq(a.camera, b.camera);
    ASSERT_EQ(a.lights.size(), b.lights.size());
    for (size_t i = 0; i < a.lights.size(); ++i)
        expectLightEq(a.lights[i], b.lights[i], "lights[" + std::to_string(i) + "]");
    ASSERT_EQ(a.volumes.size(), b.volumes.size());
    for (size_t i = 0; i < a.volumes.size(); ++i)
        expectVolumeEq(a.volumes[i], b.volumes[i], "volumes[" + std::to_string(i) + "]");
    const RenderSettings &r = a.render, &s = b.render;
    EXPECT_EQ(r.method, s.method);
    EXPECT_EQ(r.seed, s.seed);
    EXPECT_EQ(r.frame, s.frame);
    EXPECT_EQ(r.threads, s.threads);
    EXPECT_EQ(r.spp, s.spp);
    EXPECT_EQ(r.step, s.step);
    EXPECT_EQ(r.shadowMapResolution, s.shadowMapResolution);
    EXPECT_EQ(r.tolerance, s.tolerance);
    EXPECT_EQ(r.shadowStep, s.shadowStep);
    EXPECT_EQ(r.lightSamples, s.lightSamples);
    EXPECT_EQ(r.maxDepth, s.maxDepth);
    EXPECT_EQ(r.timeLimit, s.timeLimit);
    EXPECT_EQ(r.noiseTarget, s.noiseTarget);
    EXPECT_EQ(r.equiangular, s.equiangular);
    EXPECT_EQ(r.vrlPaths, s.vrlPaths);
    EXPECT_EQ(r.vrlSampling, s.vrlSampling);
    EXPECT_EQ(a.output.file, b.output.file);
    EXPECT_EQ(a.output.preview, b.output.preview);
    EXPECT_EQ(a.output.aovs, b.output.aovs);
    expectVecEq(a.background, b.background, "background");
}

}  // namespace nimbus::test
