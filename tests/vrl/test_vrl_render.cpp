// vrl as a progressive integrator (issue 15, item 3): the same seed gives the same image on any
// thread count; a render resumed from its running estimate after n samples equals the render that
// never stopped, bit for bit; max_depth 1 leaves no L2plus; a shadow caster that covers the light
// leaves no light in the medium.
#include "engine/Renderer.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

using namespace nimbus;

namespace {

Scene hazeScene()
{
    Scene s;
    s.camera.width = 12;
    s.camera.height = 10;
    s.camera.from = make_float3(0.2f, 0.3f, 4);
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 40;
    Volume v;
    v.name = "haze";
    v.source.type = SourceType::Procedural;
    v.source.generator = "sphere";
    v.source.params = {{"radius", 1.0}, {"voxel_size", 0.1}, {"falloff", 0.1}};
    v.medium.sigma_s = make_float3(1.0f, 0.8f, 0.6f);
    v.medium.sigma_a = splat(0.1f);
    v.medium.phase = NbPhase{0.5f, 0, 0, 0};
    s.volumes.push_back(v);
    Light l;
    l.name = "lamp";
    l.type = LightType::Point;
    l.position = make_float3(1.3f, 0.8f, 0.2f);
    l.intensity = splat(3.0f);
    s.lights.push_back(l);
    s.render.method = Method::Vrl;
    s.render.spp = 6;
    s.render.vrlPaths = 4;
    s.output.file = "unused.exr";
    return s;
}

bool samePixels(const Film& a, const Film& b, const char* aov)
{
    const Aov* x = a.find(aov);
    const Aov* y = b.find(aov);
    return x && y && x->pixels.size() == y->pixels.size() &&
           std::memcmp(x->pixels.data(), y->pixels.data(), x->pixels.size() * sizeof(float)) == 0;
}

double mean(const Film& f, const char* aov)
{
    const Aov* a = f.find(aov);
    double s = 0;
    for (float v : a->pixels)
        s += v;
    return s / double(a->pixels.size());
}

TEST(VrlRender, SameImageOnAnyThreadCount)
{
    Scene s = hazeScene();
    s.render.threads = 1;
    const RenderResult one = render(s);
    s.render.threads = 3;
    const RenderResult three = render(s);
    s.render.threads = 0;
    const RenderResult all = render(s);
    for (const char* aov : {"beauty", "L1", "L2plus", "variance"}) {
        EXPECT_TRUE(samePixels(one.film, three.film, aov)) << aov;
        EXPECT_TRUE(samePixels(one.film, all.film, aov)) << aov;
    }
    EXPECT_GT(mean(one.film, "L2plus"), 0.0);
}

TEST(VrlRender, ResumedEqualsUninterrupted)
{
    Scene s = hazeScene();
    RenderOptions keep;
    keep.pathtrace.keepState = true;
    s.render.spp = 3;
    const RenderResult first = render(s, keep);
    RenderOptions resume = keep;
    resume.pathtrace.resumeFrom = &first.film;
    resume.pathtrace.resumeSamples = 3;
    s.render.spp = 6;
    const RenderResult resumed = render(s, resume);
    const RenderResult whole = render(s, keep);
    for (const char* aov : {"beauty", "L0", "L1", "L2plus", "variance", "alpha"})
        EXPECT_TRUE(samePixels(resumed.film, whole.film, aov)) << aov;
}

TEST(VrlRender, MaxDepthOneHasNoL2plus)
{
    Scene s = hazeScene();
    s.render.maxDepth = 1;
    const RenderResult r = render(s);
    EXPECT_EQ(mean(r.film, "L2plus"), 0.0);
    EXPECT_GT(mean(r.film, "L1"), 0.0);
}

TEST(VrlRender, ShadowCasterAroundTheLightStopsEveryVrl)
{
    Scene s = hazeScene();
    Geometry g;
    g.name = "shell";
    g.type = GeometryType::Sphere;
    g.radius = 0.2f;
    g.transform = Transform::translate(1.3f, 0.8f, 0.2f);  // encloses the lamp
    g.holdout = false;
    g.shadows = true;
    s.geometry.push_back(g);
    const RenderResult r = render(s);
    EXPECT_EQ(mean(r.film, "L2plus"), 0.0);
    EXPECT_EQ(mean(r.film, "L1"), 0.0);
}

}  // namespace
