#include "../TestDir.h"
#include "io/Preview.h"

#include "TempDir.h"
#include "core/Error.h"
#include "render/Film.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>

using namespace nimbus;

namespace {

const std::string kShippedConfig = std::string(NIMBUS_TEST_DIR) + "/../../src/io/ocio/config.ocio";

// The shipped config explicitly, so a developer's $OCIO does not change what these tests check.
PreviewOptions shipped(const std::string& view = "", float exposure = 0.0f)
{
    PreviewOptions options;
    options.config = kShippedConfig;
    options.view = view;
    options.exposure = exposure;
    return options;
}

Film greyFilm(float value, int width = 5, int height = 4)
{
    Film film;
    film.width = width;
    film.height = height;
    Aov& beauty = film.add("beauty", 4, false);
    for (size_t i = 0; i < beauty.pixels.size(); ++i)
        beauty.pixels[i] = i % 4 == 3 ? 1.0f : value;
    return film;
}

struct Png {
    OIIO::ImageSpec spec;
    std::vector<unsigned char> pixels;
    int at(int x, int y, int c) const { return pixels[(size_t(y) * spec.width + x) * spec.nchannels + c]; }
};

Png readPng(const std::string& path)
{
    Png png;
    auto in = OIIO::ImageInput::open(path);
    EXPECT_TRUE(in) << OIIO::geterror();
    if (!in)
        return png;
    png.spec = in->spec();
    EXPECT_EQ(in->format_name(), std::string("png"));
    png.pixels.resize(png.spec.image_bytes());
    EXPECT_TRUE(in->read_image(0, 0, 0, png.spec.nchannels, OIIO::TypeDesc::UINT8, png.pixels.data()));
    return png;
}

// The sRGB encoding (IEC 61966-2-1) in 8 bits, what the "Standard" view must produce.
int srgb8(float linear)
{
    const float v = linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
    return int(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

// Sets an environment variable for one test and restores it afterwards.
class ScopedEnv {
public:
    ScopedEnv(const char* name, const char* value) : mName(name)
    {
        if (const char* old = std::getenv(name))
            mOld = old;
        if (value)
            setenv(name, value, 1);
        else
            unsetenv(name);
    }
    ~ScopedEnv()
    {
        if (mOld)
            setenv(mName, mOld->c_str(), 1);
        else
            unsetenv(mName);
    }

private:
    const char* mName;
    std::optional<std::string> mOld;
};

}  // namespace

TEST(Preview, StandardViewIsTheSrgbCurve)
{
    test::TempDir dir;
    const std::string path = dir / "preview.png";
    writePreview(greyFilm(0.18f), path, shipped("Standard"));
    const Png png = readPng(path);
    EXPECT_EQ(png.spec.width, 5);
    EXPECT_EQ(png.spec.height, 4);
    EXPECT_EQ(png.spec.nchannels, 3);
    EXPECT_EQ(png.spec.format, OIIO::TypeDesc::UINT8);
    // 0.18 -> 0.4614 -> 117.6: the view's Rec.709 -> XYZ -> Rec.709 round trip is exact to
    // float precision, so only the final rounding is allowed.
    for (int c = 0; c < 3; ++c)
        EXPECT_EQ(png.at(2, 1, c), 118) << c;
    EXPECT_EQ(dir.entryCount(), 1u);

    for (float v : {0.0f, 0.002f, 0.05f, 0.5f, 1.0f, 3.0f}) {
        writePreview(greyFilm(v), path, shipped("Standard"));
        EXPECT_NEAR(readPng(path).at(0, 0, 1), srgb8(v), 1) << v;
    }
}

TEST(Preview, ExposureIsStopsInSceneLinear)
{
    test::TempDir dir;
    const std::string path = dir / "preview.png";
    writePreview(greyFilm(0.045f), path, shipped("Standard", 2.0f));
    EXPECT_EQ(readPng(path).at(0, 0, 0), 118);
}

TEST(Preview, DefaultViewIsFilmicAndRollsOffHighlights)
{
    test::TempDir dir;
    const std::string path = dir / "preview.png";
    auto grey = [&](float v) {
        writePreview(greyFilm(v), path, shipped());
        return readPng(path).at(0, 0, 0);
    };
    const int mid = grey(0.18f), one = grey(1.0f), four = grey(4.0f), sixteen = grey(16.0f);
    // ACES 1.0 SDR video puts scene 0.18 near 10% display luminance (sRGB ~0.36), below the plain
    // curve's 118, and keeps detail above scene 1 where "Standard" has already clipped.
    EXPECT_GT(mid, 70);
    EXPECT_LT(mid, 110);
    EXPECT_LT(one, 230);
    EXPECT_LT(one, four);
    EXPECT_LT(four, sixteen);
    EXPECT_LT(four, 255);
}

TEST(Preview, OutsideTheCropIsBlack)
{
    test::TempDir dir;
    Film film = greyFilm(0.18f, 6, 4);
    film.x0 = 2;
    film.y0 = 1;
    film.x1 = 5;
    film.y1 = 3;
    writePreview(film, dir / "crop.png", shipped("Standard"));
    const Png png = readPng(dir / "crop.png");
    EXPECT_EQ(png.spec.width, 6);
    EXPECT_EQ(png.at(0, 0, 0), 0);
    EXPECT_EQ(png.at(5, 3, 1), 0);
    EXPECT_EQ(png.at(2, 1, 2), 118);
    EXPECT_EQ(png.at(4, 2, 0), 118);
}

TEST(Preview, MissingOcioFileIsOneClearError)
{
    test::TempDir dir;
    const std::string missing = dir / "no/such/config.ocio";
    ScopedEnv env("OCIO", missing.c_str());
    test::writeBytes(dir / "preview.png", "old preview");
    try {
        writePreview(greyFilm(0.18f), dir / "preview.png");
        FAIL() << "expected an Error";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find(missing), std::string::npos) << message;
        EXPECT_NE(message.find("$OCIO"), std::string::npos) << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
    EXPECT_EQ(test::readBytes(dir / "preview.png"), "old preview");
    EXPECT_EQ(dir.entryCount(), 1u);
}

TEST(Preview, OcioVariableSelectsTheConfig)
{
    test::TempDir dir;
    ScopedEnv env("OCIO", kShippedConfig.c_str());
    PreviewOptions options;
    options.view = "Standard";
    writePreview(greyFilm(0.18f), dir / "p.png", options);
    EXPECT_EQ(readPng(dir / "p.png").at(0, 0, 0), 118);
}

TEST(Preview, UnknownViewOrDisplayNamesTheChoices)
{
    test::TempDir dir;
    try {
        writePreview(greyFilm(0.18f), dir / "p.png", shipped("Filmic Very High Contrast"));
        FAIL() << "expected an Error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("'Standard'"), std::string::npos) << e.what();
    }
    PreviewOptions badDisplay = shipped();
    badDisplay.display = "Rec.2020";
    EXPECT_THROW(writePreview(greyFilm(0.18f), dir / "p.png", badDisplay), Error);
    EXPECT_EQ(dir.entryCount(), 0u);
}

TEST(Preview, FilmWithoutBeautyIsAnError)
{
    test::TempDir dir;
    Film film;
    film.width = film.height = 2;
    film.add("depth", 1, true);
    EXPECT_THROW(writePreview(film, dir / "p.png", shipped()), Error);
}

namespace {

// A frame PNG cannot compress (every 8-bit value random): about 3 bytes a pixel.
Film noiseFilm(int size)
{
    Film film = greyFilm(0.0f, size, size);
    uint32_t state = 12345;
    for (float& v : film.find("beauty")->pixels) {
        state = state * 1664525u + 1013904223u;
        v = float(state >> 8) / float(1u << 24);
    }
    return film;
}

// Writes a good preview, then one too large for the file system (or the file-size limit), and
// returns 0 when the second write threw an Error naming the path and the good file survived.
int fullDiskCheck(const std::string& path)
{
    writePreview(greyFilm(0.18f), path, shipped());
    const std::string good = test::readBytes(path);
    try {
        writePreview(noiseFilm(256), path, shipped());
        return 1;  // a truncated preview went through
    } catch (const Error& e) {
        if (std::string(e.what()).find(path) == std::string::npos)
            return 2;
    }
    return test::readBytes(path) == good ? 0 : 3;
}

}  // namespace

// Failure 2 of issue 18: on a full disk the PNG writer's error went unchecked and the truncated
// file was renamed over the good one (exit 0). A real full disk: a 64 KiB tmpfs.
TEST(Preview, FullDiskKeepsTheGoodPreview)
{
    test::TempDir dir;
    test::SmallTmpfs disk(dir.path() / "disk", 64);
    if (!disk.mounted())
        GTEST_SKIP() << "cannot mount a tmpfs here (not root); FileSizeLimitKeepsTheGoodPreview covers the error path";
    EXPECT_EQ(fullDiskCheck(disk / "preview.png"), 0) << "1: no error; 2: error without the path; 3: file changed";
    EXPECT_EQ(
        std::distance(std::filesystem::directory_iterator(dir.path() / "disk"), std::filesystem::directory_iterator()),
        1)
        << "temporary file left on the full disk";
}

// The same write error without root: files may not grow past 64 KiB in a child process.
TEST(Preview, FileSizeLimitKeepsTheGoodPreview)
{
    test::TempDir dir;
    const std::string path = dir / "preview.png";
    EXPECT_EQ(test::inChildWithFileSizeLimit(64 * 1024, [&] { return fullDiskCheck(path); }), 0)
        << "1: no error; 2: error without the path; 3: file changed; 99: threw something else";
    EXPECT_EQ(dir.entryCount(), 1u);
}
