// Determinism (STYLE rule 7) and tolerated inputs (issue 2): the same seed gives the same image
// at any thread count; a camera or a light inside a volume renders a finite, non-negative image.
#include "../render/SceneBuilders.h"

#include "engine/Renderer.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace nimbus;
using namespace nimbus::test;

namespace {

Scene smallCloudScene()
{
    Scene s = emptyScene(40, 30);
    s.volumes.push_back(proceduralCloud(0.08, splat(4.0f), splat(0.2f), 0.6f));
    s.lights.push_back(distantLight("key", make_float3(0.5f, -1.0f, -0.3f), splat(3.0f)));
    Light fill;
    fill.name = "fill";
    fill.type = LightType::Point;
    fill.position = make_float3(-3, 1, 3);
    fill.intensity = splat(4.0f);
    s.lights.push_back(fill);
    s.camera.from = make_float3(0, 0.5f, 7);
    s.camera.to = make_float3(0, 0, 0);
    s.render.spp = 2;
    return s;
}

void expectFiniteNonNegative(const Film& film)
{
    for (const Aov& a : film.aovs)
        for (float v : a.pixels) {
            ASSERT_TRUE(std::isfinite(v)) << a.name;
            ASSERT_GE(v, 0.0f) << a.name;
        }
}

}  // namespace

TEST(Determinism, SameSeedSameImageAtAnyThreadCount)
{
    Scene s = smallCloudScene();
    s.render.threads = 1;
    RenderResult one = render(s);
    s.render.threads = 2;
    RenderResult two = render(s);
    s.render.threads = 0;
    RenderResult all = render(s);
    ASSERT_EQ(one.film.aovs.size(), two.film.aovs.size());
    for (size_t i = 0; i < one.film.aovs.size(); ++i) {
        EXPECT_EQ(one.film.aovs[i].pixels, two.film.aovs[i].pixels) << one.film.aovs[i].name;
        EXPECT_EQ(one.film.aovs[i].pixels, all.film.aovs[i].pixels) << one.film.aovs[i].name;
    }
    double sum = 0;
    for (float v : one.film.find("L1")->pixels)
        sum += v;
    EXPECT_GT(sum, 0.0) << "the cloud should be lit";
    s.render.seed = 99;
    RenderResult other = render(s);
    EXPECT_NE(one.film.find("beauty")->pixels, other.film.find("beauty")->pixels) << "the seed should matter";
}

TEST(Determinism, PerLightAovsSumToL1)
{
    RenderResult r = render(smallCloudScene());
    const Aov* L1 = r.film.find("L1");
    const Aov* key = r.film.find("light_key");
    const Aov* fill = r.film.find("light_fill");
    ASSERT_TRUE(L1 && key && fill);
    for (size_t i = 0; i < L1->pixels.size(); ++i)
        ASSERT_NEAR(L1->pixels[i], key->pixels[i] + fill->pixels[i], 1e-5f * (1 + L1->pixels[i]));
    const Aov* beauty = r.film.find("beauty");
    const Aov* L0 = r.film.find("L0");
    for (size_t p = 0; p < L1->pixels.size() / 3; ++p)
        for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(beauty->pixels[p * 4 + c], L0->pixels[p * 3 + c] + L1->pixels[p * 3 + c],
                        1e-6f * (1 + beauty->pixels[p * 4 + c]));
}

TEST(Tolerated, CameraAndLightInsideTheVolume)
{
    Scene s = smallCloudScene();
    s.camera.from = make_float3(0.05f, 0.02f, 0.1f);  // inside the cloud
    s.camera.to = make_float3(0, 0, -2);
    s.lights[1].position = make_float3(0.1f, 0.1f, -0.3f);  // the point light inside too
    RenderResult r = render(s);
    expectFiniteNonNegative(r.film);
}

TEST(Tolerated, NoVolumesNoLights)
{
    Scene s = emptyScene(8, 8);
    s.background = make_float3(0.1f, 0.2f, 0.3f);
    RenderResult r = render(s);
    expectFiniteNonNegative(r.film);
    EXPECT_FLOAT_EQ(r.film.find("beauty")->pixels[2], 0.3f);
    EXPECT_FLOAT_EQ(r.film.find("alpha")->pixels[0], 0.0f);
}

TEST(Tolerated, AllLightTypesFiniteAndCrop)
{
    Scene s = smallCloudScene();
    s.camera.crop[0] = 0.25f, s.camera.crop[1] = 0.75f;
    Light spot;
    spot.name = "spot";
    spot.type = LightType::Spot;
    spot.position = make_float3(0, 4, 0);
    spot.direction = make_float3(0, -1, 0);
    spot.coneAngle = 40;
    spot.intensity = splat(10);
    Light rect;
    rect.name = "rect";
    rect.type = LightType::Rect;
    rect.center = make_float3(0, 0, -4);
    rect.normal = make_float3(0, 0, 1);
    rect.up = make_float3(0, 1, 0);
    rect.radiance = splat(1);
    Light sphere;
    sphere.name = "ball";
    sphere.type = LightType::Sphere;
    sphere.position = make_float3(3, 0, 0);
    sphere.radius = 0.5f;
    sphere.radiance = splat(2);
    Light env;
    env.name = "sky";
    env.type = LightType::Environment;
    env.radiance = make_float3(0.05f, 0.08f, 0.12f);
    Light softSun;
    softSun.name = "sun";
    softSun.type = LightType::Distant;
    softSun.angle = 5.0f;
    s.lights = {spot, rect, sphere, env, softSun};
    s.render.spp = 1;
    RenderResult r = render(s);
    expectFiniteNonNegative(r.film);
    for (const char* name : {"light_spot", "light_rect", "light_ball", "light_sky", "light_sun"}) {
        const Aov* a = r.film.find(name);
        ASSERT_NE(a, nullptr) << name;
        double sum = 0;
        for (float v : a->pixels)
            sum += v;
        EXPECT_GT(sum, 0.0) << name << " should light the cloud";
    }
    // Outside the crop nothing is rendered.
    EXPECT_EQ(r.film.find("beauty")->pixels[0], 0.0f);
    EXPECT_EQ(r.film.x0, 10);
    EXPECT_EQ(r.film.x1, 30);
}

// Camera motion blur (Tessendorf sec. 7, eq. 90): each sample draws a time in the shutter and
// the camera moves linearly, so a sideways move smears the object over the move's width in
// pixels while the image's total energy stays the static one (the object stays in frame).
TEST(MotionBlur, SidewaysMoveSmearsAndKeepsEnergy)
{
    Scene s = emptyScene(64, 32);
    Volume ball;
    ball.name = "ball";
    ball.source.type = SourceType::Procedural;
    ball.source.generator = "sphere";
    ball.source.params = {{"radius", 0.5}, {"voxel_size", 0.05}};
    ball.medium.sigma_s = splat(3.0f);
    s.volumes.push_back(ball);
    Light key;
    key.name = "key";
    key.type = LightType::Distant;
    key.direction = normalize(make_float3(0, -1, -1));
    s.lights.push_back(key);
    s.camera.from = make_float3(0, 0, 6);
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 30;
    s.render.spp = 16;
    RenderResult still = render(s);

    s.camera.hasMotion = true;
    s.camera.shutterOpen = 0, s.camera.shutterClose = 1;
    s.camera.fromClose = make_float3(1, 0, 6);  // 1 m sideways, looking parallel
    s.camera.toClose = make_float3(1, 0, 0);
    s.camera.upClose = s.camera.up;
    RenderResult blurred = render(s);

    auto columns = [&](const Film& f, double& energy) {
        const Aov* a = f.find("alpha");
        int lo = f.width, hi = -1;
        energy = 0;
        for (int y = 0; y < f.height; ++y)
            for (int x = 0; x < f.width; ++x) {
                float v = a->pixels[size_t(y) * f.width + x];
                energy += f.find("beauty")->pixels[(size_t(y) * f.width + x) * 4];
                if (v > 0.01f)
                    lo = std::min(lo, x), hi = std::max(hi, x);
            }
        return hi - lo + 1;
    };
    double eStill, eBlur;
    int wStill = columns(still.film, eStill), wBlur = columns(blurred.film, eBlur);
    // 1 m at 6 m with a 30 deg vertical fov over 32 rows: 32 / (2 * 6 tan 15 deg) ~ 10 px.
    const double movePixels = 32.0 / (2.0 * 6.0 * std::tan(15.0 * M_PI / 180.0));
    EXPECT_NEAR(wBlur - wStill, movePixels, 2.0) << wStill << " -> " << wBlur << " columns";
    // Motion blur is the time average of the still images along the move (eq. 90): compare the
    // energy with the mean of still renders at 5 evenly spaced shutter times (trapezoid rule;
    // the energy varies smoothly, by 1.6% end to end, so the rule's error is ~1e-4).
    double eMean = 0;
    for (int k = 0; k <= 4; ++k) {
        Scene still2 = s;
        still2.camera.hasMotion = false;
        still2.camera.from = make_float3(0.25f * k, 0, 6);
        still2.camera.to = make_float3(0.25f * k, 0, 0);
        double e;
        columns(render(still2).film, e);
        eMean += (k == 0 || k == 4 ? 0.5 : 1.0) * e / 4.0;
    }
    // 16 random shutter times per pixel: the image sum's relative noise is ~1/sqrt(16 * pixels
    // covered), about 0.3%; 1% is three of those.
    EXPECT_NEAR(eBlur / eMean, 1.0, 0.01);
    std::printf("motion blur: %d -> %d columns (move %.1f px), energy vs still %.4f\n", wStill, wBlur, movePixels,
                eBlur / eStill);
}
