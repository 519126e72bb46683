// Deep shadow maps on a heterogeneous medium: the compressed function of every texel keeps
// the transmittance within the stated tolerance of the uncompressed march along the same ray.
#include "HandMadeVolume.h"

#include "render/DeepShadowMap.h"
#include "render/LightCache.h"
#include "render/MarchParallelRays.h"
#include "render/RenderContext.h"
#include "scene/KernelScene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace nimbus;
using namespace nimbus::test;

namespace {

// A 40^3 volume of 5 cm voxels at [-1, 1]^3 whose density waves through 0 (clamped), up to 10.
std::shared_ptr<VolumeData> wavyVolume(const Medium& m)
{
    return handMadeVolume(
        40, 0.05f, make_float3(-1, -1, -1),
        [](int i, int j, int k) {
            float v = 1.0f + std::sin(i * 0.4f) * std::cos(j * 0.3f) + 0.5f * std::sin(k * 0.7f + i * 0.1f);
            return std::max(0.0f, v) * 4.0f;
        },
        m);
}

}  // namespace

TEST(ShadowMap, CompressionStaysWithinTolerance)
{
    Medium m;
    m.sigma_s = make_float3(2.0f, 1.0f, 0.5f);
    m.sigma_a = make_float3(0.1f, 0.3f, 0.2f);
    auto vol = wavyVolume(m);
    VolumeSet volumes({vol}, 0.5f);

    for (LightType type : {LightType::Distant, LightType::Spot, LightType::Point}) {
        Light l;
        l.type = type;
        l.direction = normalize(make_float3(-0.4f, -1.0f, 0.3f));
        l.position = make_float3(0.8f, 3.0f, -0.6f);
        l.coneAngle = 60.0f;
        DeepShadowMap::Settings s;
        s.resolution = 32;
        s.tolerance = 0.003f;
        DeepShadowMap dsm = DeepShadowMap::build(makeNbLight(l, 0), volumes, s);
        double worst = 0;
        size_t rawVertices = 0;
        std::vector<DeepShadowMap::Vertex> raw;
        for (int face = 0; face < dsm.faceCount(); ++face)
            for (int iy = 0; iy < s.resolution; ++iy)
                for (int ix = 0; ix < s.resolution; ++ix) {
                    float3 o, d;
                    dsm.texelRay(face, (ix + 0.5f) / s.resolution, (iy + 0.5f) / s.resolution, o, d);
                    DeepShadowMap::marchRay(volumes, o, d, s.stepFraction, raw);
                    rawVertices += raw.size();
                    // At the raw vertices and halfway between them (both functions are linear
                    // between raw vertices, so these bound the error everywhere).
                    for (size_t i = 0; i < raw.size(); ++i)
                        for (float w : {0.0f, 0.5f}) {
                            if (w > 0 && i + 1 == raw.size())
                                continue;
                            float z = w == 0 ? raw[i].z : 0.5f * (raw[i].z + raw[i + 1].z);
                            Rgb stored = dsm.texelOpticalDepth(face, ix, iy, z);
                            for (int c = 0; c < 3; ++c) {
                                float exact = w == 0 ? raw[i].tau[c] : 0.5f * (raw[i].tau[c] + raw[i + 1].tau[c]);
                                float got = c == 0 ? stored.x : (c == 1 ? stored.y : stored.z);
                                // Relative error, with the floor below which it turns absolute.
                                double T = std::exp(-double(exact));
                                double err = std::fabs(T - std::exp(-double(got))) /
                                             std::max(T, double(DeepShadowMap::kRelativeFloor));
                                worst = std::max(worst, err);
                            }
                        }
                }
        // The stated tolerance plus float rounding of the interpolation: optical depths up to
        // ~10 carry ~1e-6 relative rounding, 1e-5 in T / floor.
        EXPECT_LE(worst, s.tolerance + 1e-3 * s.tolerance + 1e-4) << lightTypeName(type);
        EXPECT_LT(dsm.vertexCount(), rawVertices) << "compression never adds vertices";
        std::printf("%s: %zu of %zu vertices kept, worst |dT|/max(T, floor) %.5f (tolerance %.3f)\n",
                    lightTypeName(type), dsm.vertexCount(), rawVertices, worst, s.tolerance);
    }
}

// Orthographic maps skip the texels whose rays cannot meet an occupied brick (their functions
// are empty without a march). On a sparse volume (a few cubes of density, most bricks empty) under a
// rotated placement, from several directions, every texel must still hold its march: a
// wrongly skipped texel reads 0 where the march has density.
TEST(ShadowMap, TexelsSkippedOverEmptyBricksAreThoseWithNothingToMarch)
{
    // Whole bricks of density (so it reaches every brick's faces, where a rectangle drawn too
    // tight would cut it), four of the 6^3.
    const int cubes[4][3] = {{1, 1, 3}, {3, 1, 1}, {2, 4, 2}, {5, 5, 5}};
    auto vol = handMadeVolume(48, 0.04f, make_float3(-1, -1, -1), [&](int i, int j, int k) {
        for (const auto& c : cubes)
            if (i / 8 == c[0] && j / 8 == c[1] && k / 8 == c[2])
                return 5.0f;
        return 0.0f;
    });
    vol->worldFromIndex = Transform::rotateDegrees(37.0, 0.3, 1.0, -0.2) * vol->worldFromIndex;
    vol->indexFromWorld = vol->worldFromIndex.inverse();
    vol->worldBounds = vol->worldFromIndex.box(vol->density.activeIndexBounds());
    VolumeSet volumes({vol}, 0.5f);
    size_t texelsWithDensity = 0, texels = 0;
    for (float3 dir : {make_float3(-0.4f, -1.0f, 0.3f), make_float3(1, 0.2f, 0.1f), make_float3(0.3f, 0.5f, -1)}) {
        Light l;
        l.type = LightType::Distant;
        l.direction = normalize(dir);
        DeepShadowMap::Settings s;
        s.resolution = 64;
        DeepShadowMap dsm = DeepShadowMap::build(makeNbLight(l, 0), volumes, s);
        std::vector<DeepShadowMap::Vertex> raw;
        for (int iy = 0; iy < s.resolution; ++iy)
            for (int ix = 0; ix < s.resolution; ++ix) {
                float3 o, d;
                dsm.texelRay(0, (ix + 0.5f) / s.resolution, (iy + 0.5f) / s.resolution, o, d);
                DeepShadowMap::marchRay(volumes, o, d, s.stepFraction, raw);
                ++texels;
                if (raw.empty() || raw.back().tau[0] <= 0.0f)
                    continue;
                ++texelsWithDensity;
                // Past its last vertex a texel's function is that vertex's optical depth, which
                // compression keeps exactly: equal up to float rounding; a skipped texel reads 0.
                const float stored = dsm.texelOpticalDepth(0, ix, iy, raw.back().z + 1.0f).x;
                EXPECT_NEAR(stored, raw.back().tau[0], 1e-3f * raw.back().tau[0])
                    << "texel " << ix << "," << iy << ": the map lost its march";
            }
    }
    // Not vacuous: some texels see the blobs, most see nothing.
    EXPECT_GT(texelsWithDensity, 100u);
    EXPECT_LT(texelsWithDensity, texels / 2);
    std::printf("%zu of %zu texel rays meet density\n", texelsWithDensity, texels);
}

// The light-cache bake reads an orthographic map of one grey volume from its march samples
// (DeepShadowMap::hasMarchSamples) instead of the compressed functions. Those samples must be
// the march itself, and the baked optical depth at a voxel must be the bilinear mix of the
// four nearest texels' marches, each interpolated at the voxel's depth, computed here from
// DeepShadowMap::marchRay alone.
TEST(ShadowMap, BakeFromMarchSamplesIsTheMarch)
{
    Medium m;
    m.sigma_s = splat(3.0f);
    m.sigma_a = splat(0.2f);
    auto vol = wavyVolume(m);
    VolumeSet volumes({vol}, 0.5f);
    Light l;
    l.type = LightType::Distant;
    l.direction = normalize(make_float3(-0.4f, -1.0f, 0.3f));
    DeepShadowMap::Settings s;
    s.resolution = 48;
    s.tolerance = 0.002f;
    s.stepFraction = 1.5f;
    EXPECT_FALSE(DeepShadowMap::build(makeNbLight(l, 0), volumes, s).hasMarchSamples()) << "kept unasked";
    s.keepMarchSamples = true;
    DeepShadowMap dsm = DeepShadowMap::build(makeNbLight(l, 0), volumes, s);
    ASSERT_TRUE(dsm.hasMarchSamples());
    const int res = dsm.resolution();

    // One texel's march, linear between its vertices, 0 before the first, flat after the last.
    std::vector<DeepShadowMap::Vertex> raw;
    auto marched = [&](int ix, int iy, float z) {
        ix = std::min(std::max(ix, 0), res - 1), iy = std::min(std::max(iy, 0), res - 1);
        float3 o, d;
        dsm.texelRay(0, (ix + 0.5f) / res, (iy + 0.5f) / res, o, d);
        DeepShadowMap::marchRay(volumes, o, d, s.stepFraction, raw);
        if (raw.empty() || z <= raw.front().z)
            return 0.0;
        for (size_t i = 1; i < raw.size(); ++i)
            if (z < raw[i].z) {
                const double w = (z - raw[i - 1].z) / (raw[i].z - raw[i - 1].z);
                return raw[i - 1].tau[0] + w * (raw[i].tau[0] - raw[i - 1].tau[0]);
            }
        return double(raw.back().tau[0]);
    };

    LightCache cache = LightCache::bake(dsm, volumes);
    const BrickGrid& baked = cache.grid(0);
    double worst = 0, maxTau = 0;
    size_t checked = 0;
    for (size_t b = 0; b < baked.brickCount(); b += 5) {
        const Int3 o = baked.brickOrigin(b);
        const float* values = baked.brickData(int(b));
        for (int n = 0; n < BrickGrid::kBrickValues; n += 7) {
            const int x = n % 9, y = (n / 9) % 9, z = n / 81;
            if (x == 8 || y == 8 || z == 8)
                continue;  // the apron is a neighbour's own point
            const float3 p = vol->worldFromIndex.point(make_float3(float(o.x + x), float(o.y + y), float(o.z + z)));
            int face;
            float u, v, depth;
            ASSERT_TRUE(dsm.project(p, face, u, v, depth));
            const double fx = double(u) * res - 0.5, fy = double(v) * res - 0.5;
            const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
            const double wx = fx - x0, wy = fy - y0;
            const double expected = (1 - wy) * ((1 - wx) * marched(x0, y0, depth) + wx * marched(x0 + 1, y0, depth)) +
                                    wy * ((1 - wx) * marched(x0, y0 + 1, depth) + wx * marched(x0 + 1, y0 + 1, depth));
            worst = std::max(worst, std::fabs(values[n] - expected) / std::max(1.0, expected));
            maxTau = std::max(maxTau, expected);
            ++checked;
        }
    }
    EXPECT_GT(checked, 500u);
    EXPECT_GT(maxTau, 3.0) << "the test volume should cast real shadows";
    // The bake steps (u, v, depth) across a brick in float; where neighbouring texels' depths
    // differ by ~10, a 1e-5 texel rounding moves the mix by ~1e-4. The compressed functions,
    // which may sit 0.3 off in depth where T < 1% (their bound is in T), would fail this.
    EXPECT_LT(worst, 1e-3) << "baked optical depth differs from the march";
    std::printf("%zu voxels: baked vs marched optical depth, worst relative difference %.2g (max depth %.1f)\n",
                checked, worst, maxTau);

    // A row of eight (the bake's, vectorised where the CPU has AVX2) is eight single lookups,
    // in and out of the map, before its plane and beyond the last sample.
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> across(-3.0f, float(res) + 2.0f), deep(-2.0f, 80.0f), step(-1.5f, 1.5f);
    double rowWorst = 0;
    int outside = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        const float fx = across(rng), fy = across(rng), zs = deep(rng), dx = step(rng), dy = step(rng), dz = step(rng);
        float row[8];
        dsm.greyMarchedDepthRow(fx, fy, zs, dx, dy, dz, 8, row);
        for (int i = 0; i < 8; ++i) {
            const float x = fx + float(i) * dx, y = fy + float(i) * dy, z = zs + float(i) * dz;
            const float one = dsm.greyMarchedDepthTexel(x, y, z);
            outside += one == 0.0f;
            rowWorst = std::max(rowWorst, double(std::fabs(row[i] - one)) / std::max(1.0, double(one)));
        }
    }
    // The same arithmetic in both: they differ only where the compiler does not fuse the scalar
    // loop's multiply-adds as the eight-lane one does, a few float ulps of tau (<= 40 here), so
    // ~1e-6 relative with the max(1, tau) normaliser; measured 0 with GCC's default contraction.
    EXPECT_LT(rowWorst, 1e-5) << "a row of eight differs from eight single lookups";
    std::printf("row of eight vs single lookups: worst relative difference %.2g\n", rowWorst);
    EXPECT_GT(outside, 1000) << "not vacuous: many points off the map or before its plane";

    dsm.releaseMarchSamples();
    EXPECT_FALSE(dsm.hasMarchSamples());
}

// An orthographic map's texel rays, eight at once (MarchParallelRays.h), against
// DeepShadowMap::marchRay one ray at a time: the same vertices (depths and optical depths) for
// rays through blobs in scattered bricks, under a rotated placement (so rays cross brick faces
// at every angle), in rows of eight and in a partial row. A sample within rounding of a face
// between an occupied and an unallocated brick may count in one and not the other; such rays
// are counted and bounded.
TEST(ShadowMap, EightParallelRaysAreMarchRay)
{
#if NIMBUS_EIGHT_TEXEL_MARCH
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    Medium m;
    m.sigma_s = splat(2.0f);
    m.sigma_a = splat(0.5f);
    auto vol = handMadeVolume(
        48, 0.04f, make_float3(-1, -1, -1),
        [&](int i, int j, int k) {
            if ((i / 8 + 2 * (j / 8) + 3 * (k / 8)) % 4 == 1)
                return 0.0f;  // every fourth brick unallocated: runs of samples with gaps
            return std::max(0.0f, 2.0f + std::sin(0.3f * i) + std::cos(0.5f * j + 0.2f * k));
        },
        m);
    vol->worldFromIndex = Transform::rotateDegrees(23.0, 0.2, 1.0, 0.4) * vol->worldFromIndex;
    vol->indexFromWorld = vol->worldFromIndex.inverse();
    vol->worldBounds = vol->worldFromIndex.box(vol->density.activeIndexBounds());
    VolumeSet volumes({vol}, 0.5f);
    int rays = 0, differing = 0, vertices = 0;
    double worst = 0.0;
    for (int trial = 0; trial < 60; ++trial) {
        const float3 d = normalize(make_float3(u01(rng) - 0.5f, -1.0f, u01(rng) - 0.5f) +
                                   (trial % 3 == 0 ? make_float3(0, 0, 0) : make_float3(2 * u01(rng) - 1, 0, 0)));
        float3 right, up;
        nbBasis(d, &right, &up);
        const float3 start = make_float3(0, 3, 0) + right * (2.4f * u01(rng) - 1.2f) + up * (2.4f * u01(rng) - 1.2f);
        const float stepFraction = 0.5f + 2.5f * u01(rng);
        const int n = trial % 4 == 0 ? 5 : 8;
        float3 o[8];
        std::vector<DeepShadowMap::Vertex> eight[8], one;
        std::vector<DeepShadowMap::Vertex>* out[8];
        for (int i = 0; i < n; ++i) {
            // Texel rays of one row: origins on the plane normal to d, one texel apart.
            o[i] = start - d * (dot(start, d) + 3.0f) + right * (0.013f * float(i));
            out[i] = &eight[i];
        }
        ASSERT_TRUE(marchEightParallelRays(*vol, o, n, d, stepFraction * vol->voxelSize, out));
        for (int i = 0; i < n; ++i) {
            DeepShadowMap::marchRay(volumes, o[i], d, stepFraction, one);
            ++rays;
            vertices += int(one.size());
            bool same = one.size() == eight[i].size();
            for (size_t v = 0; same && v < one.size(); ++v) {
                same = one[v].z == eight[i][v].z;
                const double rel = std::fabs(one[v].tau[0] - eight[i][v].tau[0]) / std::max(1e-3f, one[v].tau[0]);
                same = same && rel < 1e-4 && eight[i][v].tau[1] == eight[i][v].tau[0];
                if (same)
                    worst = std::max(worst, rel);
            }
            differing += !same;
        }
    }
    std::printf("%d rays, %d vertices: %d differ (a sample on a brick face); worst relative tau difference of the "
                "others %.2g\n",
                rays, vertices, differing, worst);
    EXPECT_GT(vertices, 10 * rays) << "not vacuous: the rays cross the volume";
    EXPECT_LE(differing, rays / 100);
    EXPECT_LT(worst, 1e-5);
#else
    GTEST_SKIP() << "built without AVX2 and FMA: texel rays march one at a time";
#endif
}

// Two volumes where a ray meets the second one listed before the first: a scattering layer
// (first) under an absorbing bar (second, optical depth 3.6 through its 6 cm). VolumeSet::spans
// once merged the bar's first span into the layer's last one (gridSpans joined whatever span was
// last in the list), cutting the layer's span short and dropping the bar's: the map had no shadow
// and camera rays past the bar's box lost the layer (found by SoftSun, 2026-12-03).
TEST(MultiVolume, ASecondVolumeCrossedFirstCastsItsShadow)
{
    Scene s;
    s.camera.width = 8;
    s.camera.height = 8;
    s.camera.from = make_float3(1.2f, 1.2f, 0.3f);
    s.camera.to = make_float3(0, 0, 0);
    auto box = [](const char* name, double sx, double sy, float sigmaS, float sigmaA, float y) {
        Volume v;
        v.name = name;
        v.source.type = SourceType::Procedural;
        v.source.generator = "box";
        v.source.params = {{"size_x", sx}, {"size_y", sy}, {"size_z", 3.0}, {"voxel_size", 0.02}};
        v.medium.sigma_s = splat(sigmaS);
        v.medium.sigma_a = splat(sigmaA);
        v.transform = Transform::translate(0, y, 0);
        return v;
    };
    s.volumes.push_back(box("layer", 3.0, 0.1, 1.0f, 0.0f, 0.0f));
    s.volumes.push_back(box("bar", 0.4, 0.06, 0.0f, 60.0f, 0.9f));
    Light sun;
    sun.type = LightType::Distant;
    sun.direction = make_float3(0, -1, 0);
    sun.irradiance = splat(1.0f);
    s.lights.push_back(sun);
    s.output.file = "unused.exr";
    const auto ctx = RenderContext::create(s, true);
    ASSERT_TRUE(ctx->lights[0].shadowMap);
    // Straight down through the bar, then the layer: both spans, in order.
    std::vector<Span> spans;
    ctx->volumes.spans(make_float3(0, 2, 0), make_float3(0, -1, 0), 0.0f, 10.0f, 1.0f, spans);
    ASSERT_GE(spans.size(), 2u);
    EXPECT_LT(spans.front().t0, 1.1f);   // the bar's box, from y 1.04 down
    EXPECT_GT(spans.back().t1, 2.0f);    // the layer's, down to y -0.05 or below
    // Under the bar the layer is in its shadow (e^-3.6 and the layer above the point); beside it, lit.
    const float under = ctx->lights[0].shadowMap->transmittance(make_float3(0, 0, 0)).x;
    const float beside = ctx->lights[0].shadowMap->transmittance(make_float3(1, 0, 0)).x;
    EXPECT_LT(under, 0.04f);
    EXPECT_GT(beside, 0.9f);
}
