// Environment maps (kernels/shared/envmap.h, src/render/EnvironmentMap.h): the lat-long
// orientation, the sampler against its pdf (chi-square, STYLE rule 13), the pdf against the
// map's luminance times sin(theta), and the loader's errors.
#include "../TestDir.h"
#include "render/EnvironmentMap.h"

#include "core/Error.h"

#include "EnvMapFiles.h"

#include "../../kernels/shared/rng.h"

#include <boost/math/distributions/chi_squared.hpp>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <vector>

using namespace nimbus;

namespace {

// A map with a smooth sky, a black ground (rows below the horizon, weight 0) and a sun: what the
// sampler must get right at once (zero rows, a peak, the sin(theta) weighting near the poles).
EnvironmentMap testMap(int W, int H, float rotate = 0.0f)
{
    std::vector<float> rgb(size_t(W * H) * 3, 0.0f);
    for (int j = 0; j < H / 2; ++j)
        for (int i = 0; i < W; ++i) {
            float* t = rgb.data() + 3 * (j * W + i);
            t[0] = 0.2f + 0.1f * float(i) / W, t[1] = 0.3f, t[2] = 0.5f + 0.5f * float(j) / H;
        }
    float* sun = rgb.data() + 3 * ((H / 5) * W + W / 3);
    sun[0] = sun[1] = sun[2] = 50.0f;
    return EnvironmentMap(W, H, std::move(rgb), rotate);
}

float3 near(float3 a)
{
    return make_float3(std::round(a.x * 1e4f) / 1e4f, std::round(a.y * 1e4f) / 1e4f, std::round(a.z * 1e4f) / 1e4f);
}

}  // namespace

// OpenEXR's LatLongMap convention (ImfEnvmap.h): top row +y, centre column +z, a quarter from the
// left +x; rotate turns the map counter-clockwise about +y seen from above.
TEST(EnvironmentMap, LatLongOrientation)
{
    const NbEnvMap m{64, 32, 0.0f, 0.0f};
    auto dir = [&](float u, float v) { return near(nbEnvDirection(m, u, v)); };
    EXPECT_NEAR(dir(0.5f, 0.5f).z, 1.0f, 1e-4f);
    EXPECT_NEAR(dir(0.25f, 0.5f).x, 1.0f, 1e-4f);
    EXPECT_NEAR(dir(0.75f, 0.5f).x, -1.0f, 1e-4f);
    EXPECT_NEAR(dir(0.0f, 0.5f).z, -1.0f, 1e-4f);
    EXPECT_NEAR(dir(0.3f, 0.0f).y, 1.0f, 1e-4f);
    EXPECT_NEAR(dir(0.3f, 1.0f).y, -1.0f, 1e-4f);
    // Round trip, and a 90 degree turn brings the centre column (+z) to +x.
    for (float u : {0.1f, 0.37f, 0.5f, 0.93f})
        for (float v : {0.05f, 0.5f, 0.81f}) {
            float uu, vv;
            nbEnvUv(m, nbEnvDirection(m, u, v), &uu, &vv);
            EXPECT_NEAR(uu, u, 1e-5f);
            EXPECT_NEAR(vv, v, 1e-5f);
        }
    const NbEnvMap r{64, 32, float(M_PI / 2), 0.0f};
    EXPECT_NEAR(nbEnvDirection(r, 0.5f, 0.5f).x, 1.0f, 1e-5f);
    float u, v;
    nbEnvUv(r, make_float3(1, 0, 0), &u, &v);
    EXPECT_NEAR(u, 0.5f, 1e-5f);
}

// The pdf integrates to 1 over the sphere, and over each texel to the texel's share of
// luminance * sin(theta) (pbrt-v4 sec. A.5.3), computed here from the texels alone.
TEST(EnvironmentMap, PdfIsLuminanceTimesSinTheta)
{
    const int W = 32, H = 16;
    const EnvironmentMap map = testMap(W, H, 30.0f);
    std::vector<double> f(size_t(W * H));
    double total = 0;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            const Rgb t = map.texel(i, j);
            f[size_t(j * W + i)] = (t.x + t.y + t.z) / 3.0 * std::sin(M_PI * (j + 0.5) / H);
            total += f[size_t(j * W + i)];
        }
    double sum = 0;
    const int n = 4;  // sub-samples per texel axis: pdf dOmega is constant over a texel in (u, v)
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i) {
            double p = 0;
            for (int b = 0; b < n; ++b)
                for (int a = 0; a < n; ++a) {
                    const float u = (i + (a + 0.5f) / n) / W, v = (j + (b + 0.5f) / n) / H;
                    const float3 w = nbEnvDirection(map.header(), u, v);
                    p += map.pdf(w) * 2.0 * M_PI * M_PI * std::sin(M_PI * v) / (W * H * n * n);
                }
            EXPECT_NEAR(p, f[size_t(j * W + i)] / total, 1e-5 + 1e-3 * p) << "texel " << i << ", " << j;
            sum += p;
        }
    EXPECT_NEAR(sum, 1.0, 1e-4);
}

// Samples binned by texel against the pdf integrated over each texel (chi-square, pooled to
// expectations >= 5; p-value above 1e-3 for a fixed seed).
TEST(EnvironmentMap, SamplerMatchesPdfChiSquare)
{
    const int W = 32, H = 16, samples = 400000;
    const EnvironmentMap map = testMap(W, H, -75.0f);
    std::vector<double> observed(size_t(W * H), 0.0), expected(size_t(W * H), 0.0);
    int mismatched = 0;
    for (int s = 0; s < samples; ++s) {
        NbRng r = nbRngStart(11u, 0u, nb_uint(s));
        const float u0 = nbRngNext(&r), u1 = nbRngNext(&r);
        float pdf;
        const float3 w = map.sample(u0, u1, pdf);
        ASSERT_NEAR(length(w), 1.0f, 1e-4f);
        ASSERT_GT(pdf, 0.0f);
        // The sampler's pdf is the pdf's, but for draws on a texel's edge that the round trip
        // through the direction puts in the neighbour (float rounding; a set of measure zero).
        mismatched += std::fabs(pdf - map.pdf(w)) > 1e-4f * pdf;
        float u, v;
        nbEnvUv(map.header(), w, &u, &v);
        observed[size_t(nbEnvTexel(map.header(), u, v))] += 1;
    }
    const int n = 4;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i)
            for (int b = 0; b < n; ++b)
                for (int a = 0; a < n; ++a) {
                    const float u = (i + (a + 0.5f) / n) / W, v = (j + (b + 0.5f) / n) / H;
                    expected[size_t(j * W + i)] += samples * map.pdf(nbEnvDirection(map.header(), u, v)) * 2.0 * M_PI *
                                                   M_PI * std::sin(M_PI * v) / (W * H * n * n);
                }
    double chi2 = 0, pooledO = 0, pooledE = 0, zeroO = 0;
    int dof = -1;
    for (size_t k = 0; k < expected.size(); ++k) {
        if (expected[k] == 0.0) {  // black texels: never drawn
            zeroO += observed[k];
            continue;
        }
        pooledO += observed[k];
        pooledE += expected[k];
        if (pooledE >= 5) {
            chi2 += (pooledO - pooledE) * (pooledO - pooledE) / pooledE;
            ++dof;
            pooledO = pooledE = 0;
        }
    }
    EXPECT_EQ(zeroO, 0.0);
    EXPECT_LT(mismatched, samples / 10000);
    ASSERT_GT(dof, 100);
    const double p = boost::math::cdf(boost::math::complement(boost::math::chi_squared(dof), chi2));
    EXPECT_GT(p, 1e-3) << "chi2 " << chi2 << " dof " << dof;
}

namespace {

Scene sceneWithMap(const std::string& map)
{
    Scene s;
    s.sourcePath = "sky_scene.json";
    Light l;
    l.type = LightType::Environment;
    l.map = map;
    s.lights.push_back(l);
    return s;
}

}  // namespace

TEST(EnvironmentMap, LoadsExrAndReportsBadMaps)
{
    const std::string good = test::writeEnvMap("envmap_good.exr", 8, 4, std::vector<float>(8 * 4 * 3, 0.5f));
    auto map = EnvironmentMap::load(sceneWithMap(good), 0);
    ASSERT_TRUE(map);
    EXPECT_EQ(map->width(), 8);
    EXPECT_NEAR(map->integral().y, 0.5 * 4 * M_PI, 1e-4);

    try {
        EnvironmentMap::load(sceneWithMap("/nonexistent/sky.exr"), 0);
        FAIL() << "a missing map must throw";
    } catch (const InputError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("sky_scene.json: lights[0].map"), std::string::npos) << what;
        EXPECT_NE(what.find("/nonexistent/sky.exr"), std::string::npos) << what;
    }
    std::vector<float> bad(8 * 4 * 3, 0.5f);
    bad[3 * 9 + 1] = NAN;
    const std::string nan = test::writeEnvMap("envmap_nan.exr", 8, 4, bad);
    try {
        EnvironmentMap::load(sceneWithMap(nan), 0);
        FAIL() << "a NaN texel must throw";
    } catch (const InputError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("lights[0].map"), std::string::npos) << what;
        EXPECT_NE(what.find("texel (1, 1)"), std::string::npos) << what;
    }
    const std::string text = std::string(::testing::TempDir()) + "envmap_not_an_image.exr";
    FILE* f = std::fopen(text.c_str(), "w");
    std::fputs("not an image", f);
    std::fclose(f);
    EXPECT_THROW(EnvironmentMap::load(sceneWithMap(text), 0), InputError);
}

namespace {

// The file's bytes with `patch` written over the 4 bytes at `at` bytes after `key`'s first
// occurrence (a header attribute's name), to a new file.
std::string patched(const std::string& from, const std::string& name, const std::string& key, size_t at,
                    uint32_t value)
{
    FILE* f = std::fopen(from.c_str(), "rb");
    std::string bytes;
    for (int c; f && (c = std::fgetc(f)) != EOF;)
        bytes += char(c);
    if (f)
        std::fclose(f);
    const size_t k = bytes.find(key);
    EXPECT_NE(k, std::string::npos);
    for (int b = 0; b < 4 && k != std::string::npos; ++b)
        bytes[k + at + size_t(b)] = char((value >> (8 * b)) & 0xff);
    const std::string path = std::string(::testing::TempDir()) + name;
    FILE* out = std::fopen(path.c_str(), "wb");
    std::fwrite(bytes.data(), 1, bytes.size(), out);
    std::fclose(out);
    return path;
}

std::string loadError(const std::string& path)
{
    try {
        EnvironmentMap::load(sceneWithMap(path), 0);
    } catch (const InputError& e) {
        return e.what();
    }
    return "(no error)";
}

}  // namespace

// What a header claims must fit in the file before anything is allocated (src/core/
// ImageFileCheck.h; fuzz_envmap's first finding): a string attribute of 2 GB in a 298-byte file
// (the saved finding: OpenEXR resized a string to it and the load took seconds and 2 GB), and a
// data window of 2^30 x 4 pixels in a file of a few hundred bytes.
TEST(EnvironmentMap, HeadersClaimingMoreThanTheFileHoldsAreRefusedUnread)
{
    const std::string finding =
        std::string(NIMBUS_TEST_DIR) + "/../fuzz/regressions/envmap/exr_string_attribute_claims_2gb.exr";
    const std::string what = loadError(finding);
    EXPECT_NE(what.find("lights[0].map"), std::string::npos) << what;
    EXPECT_NE(what.find("attribute 'capDate' claims 2020540435 bytes where"), std::string::npos) << what;

    const std::string good = test::writeEnvMap("envmap_window.exr", 8, 4, std::vector<float>(8 * 4 * 3, 0.5f));
    // dataWindow: "dataWindow\0box2i\0" then the size (4 bytes), xMin, yMin, xMax, yMax.
    const size_t xMax = std::string("dataWindow").size() + 1 + std::string("box2i").size() + 1 + 4 + 8;
    const std::string wide = patched(good, "envmap_wide.exr", "dataWindow", xMax, (1u << 30) - 1);
    const std::string message = loadError(wide);
    EXPECT_NE(message.find("describes 1073741824 x 4 pixels"), std::string::npos) << message;
    EXPECT_NE(message.find("more than its"), std::string::npos) << message;
}

// Saved fuzz_envmap findings whose headers describe more than the file holds, each refused
// before OpenImageIO or the loader allocates what it claims, with the line that says why:
// - OpenEXR reads a channel list up to its empty name and a fixed-size value whole, whatever the
//   attribute's size field says; where the two disagree it reads the rest of the header from
//   elsewhere than the check would (fuzz bug 9: a 204-byte file whose channel list "of 55 bytes"
//   ends elsewhere, after which OpenEXR read an opaque attribute of 842 MB);
// - it reads a value by its type whatever its name (2026-12-06: a channel list named
//   "channel\x92s" ran 18 bytes past its 73 into a string attribute that claimed 2 GB; the
//   name's byte escaped in the message);
// - OpenImageIO 2.4 opens a Radiance header without its "#?" (2026-12-06: a 161-byte
//   "v/RADIANCE" file named .exr, "-Y 4 +X 888..." read as 2^31 - 1 pixels wide; the load then
//   allocated 103 GB).
TEST(EnvironmentMap, SavedFindingsAreRefusedUnread)
{
    const struct {
        const char* file;
        const char* why;
    } findings[] = {
        {"exr_channel_list_size_disagrees_then_842mb_attribute_oom.exr",
         "attribute 'channels' (chlist) says 55 bytes but its value takes 24"},
        {"exr_misnamed_channel_list_runs_into_2gb_string.exr",
         "attribute 'channel\\x92s' (chlist) says 73 bytes but its value takes 91"},
        {"radiance_header_without_magic_width_int_max_103_gb.exr", "more than its 161 bytes can hold"},
    };
    for (const auto& f : findings) {
        const std::string what = loadError(std::string(NIMBUS_TEST_DIR) + "/../fuzz/regressions/envmap/" + f.file);
        EXPECT_NE(what.find("lights[0].map: cannot read"), std::string::npos) << f.file << ": " << what;
        EXPECT_NE(what.find(f.why), std::string::npos) << f.file << ": " << what;
    }
}

// A map that the file holds but render.memory_limit does not: refused before its pixels are
// allocated, naming the key to raise.
TEST(EnvironmentMap, MapLargerThanTheMemoryLimitIsRefusedBeforeItsPixelsAreRead)
{
    const std::string good = test::writeEnvMap("envmap_limit.exr", 64, 32, std::vector<float>(64 * 32 * 3, 0.5f));
    Scene scene = sceneWithMap(good);
    scene.render.memoryLimit = 4096.0f;
    std::string what = "(no error)";
    try {
        EnvironmentMap::load(scene, 0);
    } catch (const InputError& e) {
        what = e.what();
    }
    EXPECT_NE(what.find("lights[0].map: cannot read"), std::string::npos) << what;
    EXPECT_NE(what.find("its 64 x 32 pixels take"), std::string::npos) << what;
    EXPECT_NE(what.find("render.memory_limit (4.0 KiB)"), std::string::npos) << what;
    scene.render.memoryLimit = 0.0f;  // the default: 80% of physical memory
    EXPECT_NE(EnvironmentMap::load(scene, 0), nullptr);
}

// A map is read by the reader its extension names, and no other (src/core/OpenImageFile.h): a
// PNG named .exr is refused as "not an OpenEXR file" instead of going to every reader
// OpenImageIO has; the same PNG named .png, or without an extension, loads.
TEST(EnvironmentMap, MapIsReadAsTheFormatItsExtensionNames)
{
    const std::string dir = std::string(::testing::TempDir());
    const std::string png = dir + "envmap_real.png", misnamed = dir + "envmap_png_named.exr",
                      bare = dir + "envmap_png_no_extension";
    {
        const std::vector<float> pixels(8 * 4 * 3, 0.5f);
        auto out = OIIO::ImageOutput::create(png);
        ASSERT_TRUE(out);
        ASSERT_TRUE(out->open(png, OIIO::ImageSpec(8, 4, 3, OIIO::TypeDesc::UINT8)));
        ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()));
        ASSERT_TRUE(out->close());
    }
    std::filesystem::copy_file(png, misnamed, std::filesystem::copy_options::overwrite_existing);
    std::filesystem::copy_file(png, bare, std::filesystem::copy_options::overwrite_existing);
    const std::string what = loadError(misnamed);
    EXPECT_NE(what.find("lights[0].map: cannot read"), std::string::npos) << what;
    EXPECT_NE(what.find("is not an OpenEXR file"), std::string::npos) << what;
    EXPECT_EQ(loadError(png), "(no error)");
    EXPECT_EQ(loadError(bare), "(no error)");
}
