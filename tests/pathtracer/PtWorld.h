// PtWorld.h: scenes for the path tracer's tests, built by hand (VolumeData from functions, a
// RenderContext filled directly), so the tests depend on neither the VDB loader nor the JSON
// reader, and statistics helpers for tolerances derived from the estimator's own noise.
#pragma once

#include "pathtracer/Pathtracer.h"
#include "render/RenderContext.h"
#include "scene/KernelScene.h"
#include "volume/VolumeData.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace nimbus::pttest {

// A BrickGrid over bricks [0, nb) on each axis whose voxel (i,j,k) holds f(i,j,k,c) for every
// stored value, aprons included (voxel 8 of a brick is voxel 0 of the next).
template <class F>
BrickGrid gridFrom(Int3 nb, int channels, F f)
{
    BrickGrid g;
    g.reset({0, 0, 0}, nb, channels);
    const int S = BrickGrid::kStored;
    for (int bz = 0; bz < nb.z; ++bz)
        for (int by = 0; by < nb.y; ++by)
            for (int bx = 0; bx < nb.x; ++bx) {
                float* v = g.allocateBrick(bx, by, bz);
                for (int z = 0; z < S; ++z)
                    for (int y = 0; y < S; ++y)
                        for (int x = 0; x < S; ++x)
                            for (int c = 0; c < channels; ++c)
                                v[((z * S + y) * S + x) * channels + c] = f(bx * 8 + x, by * 8 + y, bz * 8 + z, c);
            }
    g.pruneZeroBricks();
    return g;
}

// A box volume covering world [lo, hi) with n = 8 nb voxels per axis. The density is
// density(u) at voxel centres, u in [0,1]^3 the voxel's position in the box (i / n), and the
// box's faces are sharp: index positions [0, n) hold the interpolated values, outside is 0.
inline std::shared_ptr<VolumeData> boxVolume(float3 lo, float3 hi, Int3 nb, Medium medium,
                                             std::function<float(float3)> density = nullptr,
                                             std::function<Rgb(float3)> emission = nullptr)
{
    auto v = std::make_shared<VolumeData>();
    v->name = "box";
    v->medium = medium;
    const float3 n = make_float3(float(8 * nb.x), float(8 * nb.y), float(8 * nb.z));
    v->density = gridFrom(nb, 1, [&](int i, int j, int k, int) {
        return density ? density(make_float3(i / n.x, j / n.y, k / n.z)) : 1.0f;
    });
    if (emission)
        v->emission = gridFrom(nb, 3, [&](int i, int j, int k, int c) {
            return component(emission(make_float3(i / n.x, j / n.y, k / n.z)), c);
        });
    float3 size = hi - lo;
    v->worldFromIndex =
        Transform::translate(lo.x, lo.y, lo.z) * Transform::scale(size.x / n.x, size.y / n.y, size.z / n.z);
    v->indexFromWorld = v->worldFromIndex.inverse();
    Bbox b = v->density.activeIndexBounds();
    if (v->hasEmission())
        b.expand(v->emission.activeIndexBounds());
    v->worldBounds = v->worldFromIndex.box(b);
    v->voxelSize = std::min(size.x / n.x, std::min(size.y / n.y, size.z / n.z));
    v->gridsRead = {"density"};
    return v;
}

inline Medium medium(Rgb sigma_s, Rgb sigma_a, NbPhase phase = {0, 0, 0, 0})
{
    Medium m;
    m.sigma_s = sigma_s;
    m.sigma_a = sigma_a;
    m.phase = phase;
    return m;
}

// A scene and the RenderContext the path tracer reads, filled the way RenderContext::create
// does (environment radiance becomes the background seen by camera rays).
struct World {
    Scene scene;
    std::vector<std::shared_ptr<VolumeData>> volumes;
    std::unique_ptr<RenderContext> ctx;

    World(int w, int h)
    {
        scene.camera.width = w;
        scene.camera.height = h;
        scene.render.method = Method::Pathtrace;
    }
    void addLight(Light l)
    {
        if (l.name.empty())
            l.name = std::to_string(scene.lights.size());
        scene.lights.push_back(l);
    }
    const RenderContext& context()
    {
        ctx = std::make_unique<RenderContext>();
        ctx->scene = &scene;
        ctx->volumes = VolumeSet(volumes, scene.render.step);
        ctx->background = scene.background;
        bool env = false;
        for (size_t i = 0; i < scene.lights.size(); ++i) {
            const Light& l = scene.lights[i];
            LightEntry e;
            e.light = makeNbLight(l, int(i));
            e.aov = "light_" + l.name;
            ctx->lights.push_back(std::move(e));
            if (l.type == LightType::Environment) {
                if (!env)
                    ctx->background = splat(0.0f);
                env = true;
                ctx->background += l.radiance;
            }
        }
        return *ctx;
    }
    Film render(PathtraceOptions pt = {})
    {
        Film film;
        renderPathtrace(context(), film, RenderControl{}, pt);
        return film;
    }
};

inline Light distantLight(float3 direction, Rgb irradiance)
{
    Light l;
    l.type = LightType::Distant;
    l.direction = normalize(direction);
    l.irradiance = irradiance;
    return l;
}

inline Light environmentLight(Rgb radiance)
{
    Light l;
    l.type = LightType::Environment;
    l.radiance = radiance;
    return l;
}

// Camera at `from` looking at `to`; fov in degrees.
inline void lookAt(Scene& s, float3 from, float3 to, float fov, float3 up = make_float3(0, 1, 0))
{
    s.camera.from = from;
    s.camera.to = to;
    s.camera.up = up;
    s.camera.fov = fov;
}

inline Rgb pixel3(const Film& f, const std::string& aov, int x, int y)
{
    const Aov* a = f.find(aov);
    const float* p = a->pixels.data() + (size_t(y) * f.width + x) * a->channels;
    return make_float3(p[0], p[1], p[2]);
}

inline float pixel1(const Film& f, const std::string& aov, int x, int y)
{
    const Aov* a = f.find(aov);
    return a->pixels[(size_t(y) * f.width + x) * a->channels];
}

// Mean over the pixels of one channel and the standard error of that mean estimated from the
// scatter between pixels: valid when every pixel estimates the same value independently.
struct PixelStats {
    double mean = 0, standardError = 0, spread = 0;
    int n = 0;
};

inline PixelStats pixelStats(const Film& f, const std::string& aov, int channel)
{
    const Aov* a = f.find(aov);
    PixelStats s;
    std::vector<double> v;
    for (int y = f.y0; y < f.y1; ++y)
        for (int x = f.x0; x < f.x1; ++x)
            v.push_back(a->pixels[(size_t(y) * f.width + x) * a->channels + channel]);
    s.n = int(v.size());
    for (double x : v)
        s.mean += x / s.n;
    double ss = 0;
    for (double x : v)
        ss += (x - s.mean) * (x - s.mean);
    s.spread = std::sqrt(ss / std::max(1, s.n - 1));
    s.standardError = s.spread / std::sqrt(double(s.n));
    return s;
}

// Standard error of the mean over pixels of the channel-averaged beauty, from the variance AOV.
inline double standardErrorFromVarianceAov(const Film& f)
{
    const Aov* a = f.find("variance");
    double sum = 0;
    int n = 0;
    for (int y = f.y0; y < f.y1; ++y)
        for (int x = f.x0; x < f.x1; ++x, ++n)
            sum += a->pixels[size_t(y) * f.width + x];
    return std::sqrt(sum) / std::max(1, n);
}

// Each test binary compiles kernels into its own cache directory, so the cache under test is
// cold at first and tests never touch the user's ~/.cache.
inline void useTestKernelCache(const std::string& name)
{
    static bool done = false;
    if (done)
        return;
    done = true;
    std::string dir = std::string(::testing::TempDir()) + "nimbus-kernel-cache-" + name;
    setenv("NIMBUS_CACHE_DIR", dir.c_str(), 1);
}

}  // namespace nimbus::pttest
