#include "io/ExrWriter.h"

#include "TempDir.h"
#include "core/Error.h"
#include "core/Log.h"
#include "render/Film.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <map>
#include <random>
#include <set>

#include <sys/resource.h>

using namespace nimbus;
using nimbus::test::readBytes;
using nimbus::test::writeBytes;

namespace {

// A value unique to (AOV, pixel, component), in the range half stores with 11 significant bits.
float valueAt(int aovIndex, int x, int y, int c)
{
    return 0.5f * aovIndex + 0.03125f * x + 0.25f * y + 0.1f * c + 0.01f;
}

Film makeFilm()
{
    Film film;
    film.width = 8;
    film.height = 6;
    film.x0 = 1;
    film.y0 = 2;
    film.x1 = 7;
    film.y1 = 5;
    film.add("beauty", 4, false);
    film.add("L0", 3, false);
    film.add("alpha", 1, true);
    film.add("depth", 1, true);
    film.add("light_key", 3, false);
    for (size_t a = 0; a < film.aovs.size(); ++a) {
        Aov& aov = film.aovs[a];
        for (int y = 0; y < film.height; ++y)
            for (int x = 0; x < film.width; ++x)
                for (int c = 0; c < aov.channels; ++c)
                    film.pixel(aov, x, y)[c] = valueAt(int(a), x, y, c);
    }
    // A depth beyond half's range (65504) shows that data AOVs really are float.
    film.pixel(*film.find("depth"), 3, 3)[0] = 1.0e6f;
    film.metadata = {{"version", "0.1.0"},
                     {"method", "wkb"},
                     {"seed", "42"},
                     {"render_time", "12.5"},
                     {"settings", "{\"spp\": 64}"}};
    return film;
}

struct ReadBack {
    OIIO::ImageSpec spec;
    std::map<std::string, int> index;
    std::vector<float> pixels;

    OIIO::TypeDesc format(const std::string& channel) const
    {
        const int c = index.at(channel);
        return spec.channelformats.empty() ? spec.format : spec.channelformats[c];
    }
    float at(const std::string& channel, int x, int y) const
    {
        return pixels[(size_t(y - spec.y) * spec.width + (x - spec.x)) * spec.nchannels + index.at(channel)];
    }
};

ReadBack readExr(const std::string& path)
{
    auto in = OIIO::ImageInput::open(path);
    EXPECT_TRUE(in) << OIIO::geterror();
    ReadBack r;
    if (!in)
        return r;
    r.spec = in->spec();
    for (int c = 0; c < r.spec.nchannels; ++c)
        r.index[r.spec.channelnames[c]] = c;
    r.pixels.resize(size_t(r.spec.width) * r.spec.height * r.spec.nchannels);
    EXPECT_TRUE(in->read_image(0, 0, 0, r.spec.nchannels, OIIO::TypeDesc::FLOAT, r.pixels.data())) << in->geterror();
    EXPECT_EQ(in->current_subimage(), 0);
    EXPECT_FALSE(in->seek_subimage(1, 0)) << "expected a single part";
    return r;
}

// Half keeps 11 significant bits: round-to-nearest is off by at most 2^-11 relative.
float halfTolerance(float v)
{
    return std::ldexp(std::fabs(v), -11);
}

}  // namespace

TEST(ExrWriter, LayersChannelsFormatsWindowsAndMetadata)
{
    test::TempDir dir;
    const std::string path = dir / "frame.exr";
    const Film film = makeFilm();
    writeExr(film, path);
    EXPECT_EQ(dir.entryCount(), 1u) << "temporary file left behind";

    const ReadBack r = readExr(path);
    std::set<std::string> names;
    for (const auto& [name, c] : r.index)
        names.insert(name);
    // OpenEXR's conventions: the main layer R, G, B, A and a single Z; 1-channel AOVs one
    // channel each, named by meaning.
    const std::set<std::string> expected = {
        "R",    "G",    "B",    "A",       "Z",       "beauty.R",    "beauty.G",    "beauty.B",   "beauty.A",
        "L0.R", "L0.G", "L0.B", "alpha.A", "depth.Z", "light_key.R", "light_key.G", "light_key.B"};
    EXPECT_EQ(names, expected);
    EXPECT_EQ(r.spec.nchannels, int(expected.size()));

    for (const char* half : {"R", "G", "B", "A", "beauty.R", "beauty.A", "L0.G", "light_key.B"})
        EXPECT_EQ(r.format(half), OIIO::TypeDesc::HALF) << half;
    for (const char* full : {"Z", "alpha.A", "depth.Z"})
        EXPECT_EQ(r.format(full), OIIO::TypeDesc::FLOAT) << full;

    EXPECT_EQ(r.spec.x, 1);
    EXPECT_EQ(r.spec.y, 2);
    EXPECT_EQ(r.spec.width, 6);
    EXPECT_EQ(r.spec.height, 3);
    EXPECT_EQ(r.spec.full_x, 0);
    EXPECT_EQ(r.spec.full_y, 0);
    EXPECT_EQ(r.spec.full_width, 8);
    EXPECT_EQ(r.spec.full_height, 6);
    EXPECT_EQ(r.spec.tile_width, 0) << "expected scanlines";

    EXPECT_EQ(r.spec.get_string_attribute("compression"), "zip");
    EXPECT_EQ(r.spec.get_string_attribute("nimbus:version"), "0.1.0");
    EXPECT_EQ(r.spec.get_string_attribute("nimbus:method"), "wkb");
    EXPECT_EQ(r.spec.get_string_attribute("nimbus:seed"), "42");
    EXPECT_EQ(r.spec.get_string_attribute("nimbus:render_time"), "12.5");
    EXPECT_EQ(r.spec.get_string_attribute("nimbus:settings"), "{\"spp\": 64}");
}

TEST(ExrWriter, ValuesRoundTrip)
{
    test::TempDir dir;
    const std::string path = dir / "frame.exr";
    const Film film = makeFilm();
    writeExr(film, path);
    const ReadBack r = readExr(path);
    const char* const rgba[] = {"R", "G", "B", "A"};

    for (int y = film.y0; y < film.y1; ++y)
        for (int x = film.x0; x < film.x1; ++x) {
            for (size_t a = 0; a < film.aovs.size(); ++a) {
                const Aov& aov = film.aovs[a];
                for (int c = 0; c < aov.channels; ++c) {
                    const float want = aov.pixels[(size_t(y) * film.width + x) * aov.channels + c];
                    const std::string name = aov.name + "." +
                                             (aov.channels > 1      ? rgba[c]
                                              : aov.name == "alpha" ? "A"
                                                                    : "Z");
                    const float got = r.at(name, x, y);
                    if (aov.isData)
                        EXPECT_EQ(got, want) << name << " at " << x << "," << y;
                    else
                        EXPECT_NEAR(got, want, halfTolerance(want)) << name << " at " << x << "," << y;
                }
            }
            const Aov& beauty = *film.find("beauty");
            for (int c = 0; c < 4; ++c) {
                const float want = beauty.pixels[(size_t(y) * film.width + x) * 4 + c];
                EXPECT_NEAR(r.at(rgba[c], x, y), want, halfTolerance(want)) << rgba[c] << " at " << x << "," << y;
            }
            EXPECT_EQ(r.at("Z", x, y), film.find("depth")->pixels[size_t(y) * film.width + x]);
        }
    EXPECT_EQ(r.at("depth.Z", 3, 3), 1.0e6f);
    EXPECT_EQ(r.at("Z", 3, 3), 1.0e6f);
}

// What a compositor's reader does: OpenImageIO names the alpha and depth channels of the part
// from the channel names alone, A and Z, and reads them by those indices.
TEST(ExrWriter, CompositingReadFindsAlphaInAAndDepthInZ)
{
    test::TempDir dir;
    const Film film = makeFilm();
    writeExr(film, dir / "frame.exr");
    const ReadBack r = readExr(dir / "frame.exr");
    ASSERT_GE(r.spec.alpha_channel, 0);
    ASSERT_GE(r.spec.z_channel, 0);
    EXPECT_EQ(r.spec.channelnames[r.spec.alpha_channel], "A");
    EXPECT_EQ(r.spec.channelnames[r.spec.z_channel], "Z");
    const Aov& beauty = *film.find("beauty");
    const Aov& depth = *film.find("depth");
    for (int y = film.y0; y < film.y1; ++y)
        for (int x = film.x0; x < film.x1; ++x) {
            const size_t i = (size_t(y - r.spec.y) * r.spec.width + (x - r.spec.x)) * r.spec.nchannels;
            const float alpha = beauty.pixels[(size_t(y) * film.width + x) * 4 + 3];
            EXPECT_NEAR(r.pixels[i + r.spec.alpha_channel], alpha, halfTolerance(alpha)) << x << "," << y;
            EXPECT_EQ(r.pixels[i + r.spec.z_channel], depth.pixels[size_t(y) * film.width + x]) << x << "," << y;
        }
}

// Typed metadata keep their type; the camera matrices are OpenEXR's m44f standard attributes.
TEST(ExrWriter, TypedMetadataAndCameraAttributes)
{
    test::TempDir dir;
    Film film = makeFilm();
    Matrix44 m;
    for (int i = 0; i < 16; ++i)
        m[i] = 0.5f * float(i) - 3.0f;
    film.set("complete", 0);
    film.set("samples", 6.0e9);
    film.set("worldToCamera", m);
    film.set("worldToNDC", m);
    writeExr(film, dir / "frame.exr");
    const ReadBack r = readExr(dir / "frame.exr");
    EXPECT_EQ(r.spec.get_int_attribute("nimbus:complete", -1), 0);
    const OIIO::ParamValue* samples = r.spec.find_attribute("nimbus:samples");
    ASSERT_TRUE(samples);
    EXPECT_EQ(samples->type(), OIIO::TypeDesc::DOUBLE);
    EXPECT_EQ(samples->get<double>(), 6.0e9);
    for (const char* name : {"worldtocamera", "worldtoNDC"}) {
        const OIIO::ParamValue* p = r.spec.find_attribute(name);
        ASSERT_TRUE(p) << name;
        EXPECT_EQ(p->type(), OIIO::TypeMatrix44) << name;
        for (int i = 0; i < 16; ++i)
            EXPECT_EQ(p->get<float>(i), m[i]) << name << "[" << i << "]";
    }
}

TEST(ExrWriter, PlainAlphaFromAlphaAovOrOpaque)
{
    test::TempDir dir;
    Film film;
    film.width = 2;
    film.height = 2;
    film.add("beauty", 3, false).pixels.assign(12, 0.5f);
    writeExr(film, dir / "opaque.exr");
    EXPECT_EQ(readExr(dir / "opaque.exr").at("A", 1, 1), 1.0f);

    film.add("alpha", 1, true).pixels.assign(4, 0.25f);
    writeExr(film, dir / "alpha.exr");
    const ReadBack r = readExr(dir / "alpha.exr");
    EXPECT_EQ(r.at("A", 0, 1), 0.25f);
    EXPECT_EQ(r.at("alpha.A", 0, 1), 0.25f);
    EXPECT_EQ(r.index.count("beauty.A"), 0u);
    EXPECT_EQ(r.index.count("Z"), 0u) << "no depth AOV, no Z";
    EXPECT_EQ(r.spec.x, 0);
    EXPECT_EQ(r.spec.width, 2) << "an unset crop is the full frame";
}

TEST(ExrWriter, CreatesParentDirectoriesAndOverwrites)
{
    test::TempDir dir;
    const std::string path = dir / "out/shot010/frame.0001.exr";
    writeExr(makeFilm(), path);
    ASSERT_TRUE(std::filesystem::is_regular_file(path));
    Film other = makeFilm();
    other.metadata = {{"seed", "7"}};
    writeExr(other, path);
    EXPECT_EQ(readExr(path).spec.get_string_attribute("nimbus:seed"), "7");
    EXPECT_EQ(std::filesystem::path(path).parent_path().empty(), false);
    size_t entries = 0;
    for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(path).parent_path()))
        entries += entry.is_regular_file();
    EXPECT_EQ(entries, 1u);
}

TEST(ExrWriter, UnwritableTargetsThrowAndLeaveOtherFilesUntouched)
{
    test::TempDir dir;
    const std::string existing = dir / "existing.exr";
    writeExr(makeFilm(), existing);
    const std::string bytes = readBytes(existing);

    std::filesystem::create_directories(dir / "frame_dir.exr");
    writeBytes(dir / "plain_file", "not a directory");
    for (const std::string& bad : {dir / "frame_dir.exr", dir / "plain_file/frame.exr"}) {
        try {
            writeExr(makeFilm(), bad);
            ADD_FAILURE() << "writing " << bad << " did not throw";
        } catch (const Error& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find(bad), std::string::npos) << message;
            EXPECT_EQ(message.find('\n'), std::string::npos) << message;
        }
    }
    EXPECT_EQ(readBytes(existing), bytes);
    EXPECT_EQ(dir.entryCount(), 3u) << "temporary file left behind";  // existing, frame_dir.exr, plain_file
}

TEST(ExrWriter, FailedWriteOverExistingFileKeepsItsBytes)
{
    test::TempDir dir;
    const std::string path = dir / "frame.exr";
    writeExr(makeFilm(), path);
    const std::string bytes = readBytes(path);

    Film broken = makeFilm();
    broken.find("L0")->pixels.resize(5);  // a buffer that does not match the film
    EXPECT_THROW(writeExr(broken, path), Error);
    Film badCrop = makeFilm();
    badCrop.x1 = 9;
    EXPECT_THROW(writeExr(badCrop, path), Error);
    Film dotted = makeFilm();
    dotted.aovs[1].name = "L0.diffuse";
    EXPECT_THROW(writeExr(dotted, path), Error);

    EXPECT_EQ(readBytes(path), bytes);
    EXPECT_EQ(dir.entryCount(), 1u);
}

// A write that fails half-way through the file (the disk fills up): a file-size limit makes
// write(2) fail with EFBIG after the first 4 KiB, even for root, where permissions would not.
TEST(ExrWriter, WriteFailingMidFileKeepsExistingBytes)
{
    test::TempDir dir;
    const std::string path = dir / "frame.exr";
    writeBytes(path, "the previous frame");

    Film noisy;
    noisy.width = noisy.height = 128;
    Aov& beauty = noisy.add("beauty", 4, false);
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
    for (float& v : beauty.pixels)
        v = uniform(rng);  // noise does not compress: the file is far over the limit

    rlimit old{};
    ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
    auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
    rlimit limited = old;
    limited.rlim_cur = 4096;
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limited), 0);
    bool threw = false;
    std::string message;
    try {
        writeExr(noisy, path);
    } catch (const Error& e) {
        threw = true;
        message = e.what();
    }
    setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, oldHandler);

    EXPECT_TRUE(threw);
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_EQ(readBytes(path), "the previous frame");
    EXPECT_EQ(dir.entryCount(), 1u) << "temporary file left behind";
}

// The EXR on a full disk (a 64 KiB tmpfs): OpenImageIO's error, or the stream's, fails the
// write; the earlier file keeps its bytes and no temporary file remains.
TEST(ExrWriter, FullDiskKeepsTheEarlierFile)
{
    test::TempDir dir;
    test::SmallTmpfs disk(dir.path() / "disk", 64);
    if (!disk.mounted())
        GTEST_SKIP() << "cannot mount a tmpfs here (not root)";
    const std::string path = disk / "frame.exr";
    writeExr(makeFilm(), path);
    const std::string bytes = readBytes(path);
    Film big;
    big.width = big.height = 256;
    Aov& beauty = big.add("beauty", 4, true);  // float, noise: zip cannot shrink it below 1 MiB
    uint32_t state = 7;
    for (float& v : beauty.pixels) {
        state = state * 1664525u + 1013904223u;
        v = float(state) / 4294967296.0f;
    }
    try {
        writeExr(big, path);
        ADD_FAILURE() << "a 1 MiB EXR was written on a 64 KiB disk";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    EXPECT_EQ(readBytes(path), bytes);
    EXPECT_EQ(
        std::distance(std::filesystem::directory_iterator(dir.path() / "disk"), std::filesystem::directory_iterator()),
        1);
}

// Failure 8 of issue 18: values above 65504 became inf in half channels without a word. They
// are written as +-65504, and one warning names each AOV with its count of pixels; float (data)
// AOVs keep their values.
TEST(ExrWriter, ValuesBeyondHalfAreClampedWithOneWarningNamingTheAov)
{
    test::TempDir dir;
    Film film = makeFilm();
    film.pixel(*film.find("L0"), 2, 3)[1] = 1e6f;
    film.pixel(*film.find("L0"), 2, 3)[2] = -2e5f;  // the same pixel: counted once
    film.pixel(*film.find("L0"), 4, 4)[0] = 70000.0f;
    std::vector<std::string> warnings;
    setLogSink([&](LogLevel level, const std::string& m) {
        if (level == LogLevel::Warning)
            warnings.push_back(m);
    });
    const std::string path = dir / "bright.exr";
    writeExr(film, path);
    setLogSink(nullptr);
    const ReadBack r = readExr(path);
    EXPECT_EQ(r.at("L0.G", 2, 3), 65504.0f);
    EXPECT_EQ(r.at("L0.B", 2, 3), -65504.0f);
    EXPECT_EQ(r.at("L0.R", 4, 4), 65504.0f);
    EXPECT_EQ(r.at("depth.Z", 3, 3), 1.0e6f) << "float channels are not clamped";
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("L0 (2 pixels)"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find(path), std::string::npos) << warnings[0];
}
