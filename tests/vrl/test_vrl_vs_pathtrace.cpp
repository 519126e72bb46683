// vrl against the path tracer (issue 15, "How it is checked"): both are unbiased estimators of
// the same image, so on every scene their L2plus and beauty must agree within the noise.
//
// The noise is measured, not assumed: each method renders the scene with kSeeds independent
// seeds; a statistic (the image mean of a term's channel average, and the same over each image
// quadrant) has a mean and a standard error across the seeds, and the two methods' means must
// agree within 4 standard errors of their combined noise, sqrt(se_vrl^2 + se_pt^2). The quadrants
// catch a VRL contribution put in the wrong place that the image mean would average away.
// L1 is checked the same way (both compute it with the same estimator, on different streams).
//
// Scenes, small (16 x 16 pixels) so that a case takes seconds: a homogeneous sphere with a point
// light inside and outside, a spot light beam through haze, a distant light on a cloud, a
// chromatic medium, forward (g = 0.9) and backward (g = -0.5) scattering media, and a shadow
// caster between a light and the medium (docs/geometry.md: VRLs stop at it).
#include "engine/Renderer.h"

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace nimbus;

namespace {

constexpr int kSeeds = 10;
constexpr int kSize = 16;

Volume sphereVolume(float radius, float sigmaT, Rgb albedo, float g, double voxel = 0.1)
{
    Volume v;
    v.name = "medium";
    v.source.type = SourceType::Procedural;
    v.source.generator = "sphere";
    v.source.params = {{"radius", radius}, {"voxel_size", voxel}, {"falloff", voxel}};
    v.medium.sigma_s = albedo * sigmaT;
    v.medium.sigma_a = (splat(1.0f) - albedo) * sigmaT;
    v.medium.phase = NbPhase{g, 0, 0, 0};
    return v;
}

Scene baseScene(float3 from)
{
    Scene s;
    s.camera.width = kSize;
    s.camera.height = kSize;
    s.camera.from = from;
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 40;
    s.render.pixelFilter = PixelFilter::Box;
    s.render.filterWidth = 1.0f;
    s.output.file = "unused.exr";
    return s;
}

Light pointLight(float3 p, float intensity)
{
    Light l;
    l.name = "lamp";
    l.type = LightType::Point;
    l.position = p;
    l.intensity = splat(intensity);
    return l;
}

struct Case {
    std::string name;
    Scene scene;
    int sppPt, sppVrl;
};

std::vector<Case> cases()
{
    std::vector<Case> out;
    {
        Scene s = baseScene(make_float3(0, 0.3f, 4));
        s.volumes.push_back(sphereVolume(1.0f, 1.0f, splat(0.9f), 0.0f));
        s.lights.push_back(pointLight(make_float3(0.2f, 0.1f, 0), 1.0f));
        out.push_back({"point_inside", s, 64, 32});
    }
    {
        Scene s = baseScene(make_float3(0, 0.3f, 4));
        s.volumes.push_back(sphereVolume(1.0f, 1.5f, splat(0.95f), 0.3f));
        s.lights.push_back(pointLight(make_float3(1.6f, 1.0f, 0.5f), 3.0f));
        out.push_back({"point_outside", s, 64, 32});
    }
    {
        // A spot beam crossing a haze box seen from the side.
        Scene s = baseScene(make_float3(0, 0, 4));
        Volume v;
        v.name = "haze";
        v.source.type = SourceType::Procedural;
        v.source.generator = "box";
        v.source.params = {{"size", 2.5}, {"voxel_size", 0.125}};
        v.medium.sigma_s = splat(0.4f);
        v.medium.sigma_a = splat(0.05f);
        v.medium.phase = NbPhase{0.4f, 0, 0, 0};
        s.volumes.push_back(v);
        Light l;
        l.name = "spot";
        l.type = LightType::Spot;
        l.position = make_float3(-1.0f, 1.6f, 0);
        l.direction = normalize(make_float3(0.5f, -1, 0));
        l.intensity = splat(6.0f);
        l.coneAngle = 30;
        l.coneSoftness = 5;
        s.lights.push_back(l);
        out.push_back({"spot_haze", s, 64, 32});
    }
    {
        Scene s = baseScene(make_float3(0.5f, 0.4f, 4));
        Volume v;
        v.name = "cloud";
        v.source.type = SourceType::Procedural;
        v.source.generator = "cloud";
        v.source.params = {{"radius", 1.0}, {"voxel_size", 0.06}, {"seed", 3}};
        v.medium.sigma_s = splat(3.0f);
        v.medium.sigma_a = splat(0.1f);
        v.medium.phase = NbPhase{0.6f, 0, 0, 0};
        s.volumes.push_back(v);
        Light sun;
        sun.name = "sun";
        sun.type = LightType::Distant;
        sun.direction = normalize(make_float3(0.3f, -1, -0.4f));
        sun.irradiance = splat(2.0f);
        s.lights.push_back(sun);
        out.push_back({"distant_cloud", s, 64, 32});
    }
    {
        Scene s = baseScene(make_float3(0, 0.3f, 4));
        Volume v = sphereVolume(1.0f, 1.2f, splat(0.9f), 0.2f);
        v.medium.sigma_s = make_float3(1.4f, 0.9f, 0.4f);
        v.medium.sigma_a = make_float3(0.05f, 0.2f, 0.4f);
        s.volumes.push_back(v);
        s.lights.push_back(pointLight(make_float3(-1.4f, 1.2f, 0.6f), 3.0f));
        out.push_back({"chromatic", s, 64, 32});
    }
    {
        Scene s = baseScene(make_float3(0, 0.3f, 4));
        s.volumes.push_back(sphereVolume(1.0f, 2.0f, splat(0.95f), 0.9f));
        s.lights.push_back(pointLight(make_float3(0.3f, 0.2f, -1.8f), 3.0f));  // behind: forward scattering
        out.push_back({"forward_g0.9", s, 64, 32});
    }
    {
        Scene s = baseScene(make_float3(0, 0.3f, 4));
        s.volumes.push_back(sphereVolume(1.0f, 2.0f, splat(0.95f), -0.5f));
        s.lights.push_back(pointLight(make_float3(0.6f, 0.4f, 2.2f), 3.0f));  // in front: back scattering
        out.push_back({"backward_g-0.5", s, 64, 32});
    }
    {
        // A sphere shadow caster (not a holdout) between the lamp and the medium.
        Scene s = baseScene(make_float3(0, 0.3f, 4));
        s.volumes.push_back(sphereVolume(1.0f, 1.0f, splat(0.9f), 0.0f));
        s.lights.push_back(pointLight(make_float3(0, 2.4f, 0), 4.0f));
        Geometry g;
        g.name = "blocker";
        g.type = GeometryType::Sphere;
        g.radius = 0.35f;
        g.transform = Transform::translate(0.15f, 1.45f, 0);
        g.holdout = false;
        g.shadows = true;
        s.geometry.push_back(g);
        out.push_back({"shadow_caster", s, 64, 32});
    }
    return out;
}

// Per seed: the channel-average mean of an AOV over the image and over its four quadrants.
struct Stats {
    std::vector<double> v[3][5];  // [L1, L2plus, beauty][whole, quadrants]
};

void addRender(const Scene& scene, Stats& st)
{
    const RenderResult r = render(scene);
    const char* names[3] = {"L1", "L2plus", "beauty"};
    for (int a = 0; a < 3; ++a) {
        const Aov* aov = r.film.find(names[a]);
        ASSERT_NE(aov, nullptr) << names[a];
        double sums[5] = {0, 0, 0, 0, 0};
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x) {
                const float* p = aov->pixels.data() + size_t(y * kSize + x) * size_t(aov->channels);
                const double m = (double(p[0]) + p[1] + p[2]) / 3.0;
                sums[0] += m;
                sums[1 + (y >= kSize / 2) * 2 + (x >= kSize / 2)] += m;
            }
        st.v[a][0].push_back(sums[0] / (kSize * kSize));
        for (int q = 1; q < 5; ++q)
            st.v[a][q].push_back(sums[q] / (kSize * kSize / 4));
    }
}

void meanSe(const std::vector<double>& x, double& mean, double& se)
{
    mean = 0;
    for (double v : x)
        mean += v;
    mean /= double(x.size());
    double ss = 0;
    for (double v : x)
        ss += (v - mean) * (v - mean);
    se = std::sqrt(ss / double(x.size() - 1) / double(x.size()));
}

class VrlVsPathtrace : public ::testing::TestWithParam<int> {};

TEST_P(VrlVsPathtrace, TermsAgreeWithinNoise)
{
    setenv("NIMBUS_CACHE_DIR", (std::string(::testing::TempDir()) + "nimbus-kernel-cache-vrl").c_str(), 1);
    const Case c = cases()[size_t(GetParam())];
    Stats pt, vrl;
    for (int k = 0; k < kSeeds; ++k) {
        Scene s = c.scene;
        s.render.seed = uint32_t(101 + k);
        s.render.method = Method::Pathtrace;
        s.render.spp = c.sppPt;
        addRender(s, pt);
        s.render.method = Method::Vrl;
        s.render.spp = c.sppVrl;
        addRender(s, vrl);
    }
    const char* names[3] = {"L1", "L2plus", "beauty"};
    const char* regions[5] = {"image", "top left", "top right", "bottom left", "bottom right"};
    for (int a = 0; a < 3; ++a)
        for (int q = 0; q < 5; ++q) {
            double mp, sp, mv, sv;
            meanSe(pt.v[a][q], mp, sp);
            meanSe(vrl.v[a][q], mv, sv);
            const double se = std::sqrt(sp * sp + sv * sv);
            if (q == 0)
                std::printf("%s %s: pathtrace %.5g +- %.2g, vrl %.5g +- %.2g (z %.2f)\n", c.name.c_str(), names[a], mp,
                            sp, mv, sv, se > 0 ? (mv - mp) / se : 0.0);
            EXPECT_LE(std::fabs(mv - mp), 4 * se + 1e-7 * std::fabs(mp))
                << c.name << " " << names[a] << " over the " << regions[q] << ": pathtrace " << mp << " +- " << sp
                << ", vrl " << mv << " +- " << sv;
        }
    // The scene is not trivially dark: the comparison has something to compare.
    double m, s;
    meanSe(pt.v[1][0], m, s);
    EXPECT_GT(m, 10 * s) << c.name << ": L2plus is lost in the noise";
}

INSTANTIATE_TEST_SUITE_P(Scenes, VrlVsPathtrace, ::testing::Range(0, 8), [](const auto& info) {
    std::string n = cases()[size_t(info.param)].name;
    for (char& ch : n)
        if (!std::isalnum(static_cast<unsigned char>(ch)))
            ch = '_';
    return n;
});

}  // namespace
