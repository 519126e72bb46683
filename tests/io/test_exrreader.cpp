// ExrReader (io/ExrReader.h): a film written by writeExr and read back is the same film: its
// size, data window, AOVs (names, channels, data or colour) and metadata; colour values exactly
// as half rounded them, data values exactly. What merge and --resume rely on.
#include "io/ExrReader.h"
#include "io/ExrWriter.h"

#include "TempDir.h"
#include "core/Error.h"
#include "render/Film.h"

#include <Imath/half.h>
#include <gtest/gtest.h>

#include <fstream>
#include <variant>

using namespace nimbus;

namespace {

Film filmWithEveryKind()
{
    Film film;
    film.width = 9, film.height = 7;
    film.x0 = 2, film.x1 = 8, film.y0 = 1, film.y1 = 6;
    film.add("beauty", 4, false);
    film.add("L2plus", 3, false);
    film.add("depth", 1, true);
    film.add("variance", 1, true);
    film.add("state_m2_y", 1, true);
    film.add("state_light_key", 3, true);
    int k = 0;
    for (Aov& aov : film.aovs)
        for (int y = film.y0; y < film.y1; ++y)
            for (int x = film.x0; x < film.x1; ++x)
                for (int c = 0; c < aov.channels; ++c)
                    film.pixel(aov, x, y)[c] = 0.1234567f * float(k) + 1e-7f * float(k * k), ++k;
    film.set("method", std::string("pathtrace"));
    film.set("frame", 12);
    film.set("samples", 123456789.25);
    film.set("worldToCamera", Matrix44{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16});
    return film;
}

// One component of a pixel of a const film.
float componentAt(const Film& film, const Aov& aov, int x, int y, int c)
{
    return aov.pixels[(size_t(y) * size_t(film.width) + size_t(x)) * size_t(aov.channels) + size_t(c)];
}

}  // namespace

TEST(ExrReader, ReadsBackWhatTheWriterWrote)
{
    test::TempDir dir;
    const Film film = filmWithEveryKind();
    writeExr(film, dir / "f.exr");
    const Film back = readExr(dir / "f.exr");
    EXPECT_EQ(back.width, film.width);
    EXPECT_EQ(back.height, film.height);
    EXPECT_EQ(back.x0, film.x0);
    EXPECT_EQ(back.x1, film.x1);
    EXPECT_EQ(back.y0, film.y0);
    EXPECT_EQ(back.y1, film.y1);
    ASSERT_EQ(back.aovs.size(), film.aovs.size());  // the main layer's R, G, B, A, Z are not AOVs
    for (const Aov& aov : film.aovs) {
        const Aov* b = back.find(aov.name);
        ASSERT_TRUE(b) << aov.name;
        EXPECT_EQ(b->channels, aov.channels) << aov.name;
        EXPECT_EQ(b->isData, aov.isData) << aov.name;
        for (int y = film.y0; y < film.y1; ++y)
            for (int x = film.x0; x < film.x1; ++x)
                for (int c = 0; c < aov.channels; ++c) {
                    const float v = componentAt(film, aov, x, y, c);
                    const float want = aov.isData ? v : float(Imath::half(v));
                    ASSERT_EQ(componentAt(back, *b, x, y, c), want) << aov.name << " at " << x << ", " << y << " c" << c;
                }
    }
    ASSERT_TRUE(back.meta("method"));
    EXPECT_EQ(std::get<std::string>(*back.meta("method")), "pathtrace");
    EXPECT_EQ(std::get<int>(*back.meta("frame")), 12);
    EXPECT_EQ(std::get<double>(*back.meta("samples")), 123456789.25);
    EXPECT_EQ(std::get<Matrix44>(*back.meta("worldToCamera"))[14], 15.0f);

    // Written again, the pixels are the first file's bit for bit (what merge's tiles rely on).
    writeExr(back, dir / "g.exr");
    const Film again = readExr(dir / "g.exr");
    for (const Aov& aov : back.aovs)
        EXPECT_EQ(std::vector<float>(again.find(aov.name)->pixels.begin(), again.find(aov.name)->pixels.end()),
                  std::vector<float>(aov.pixels.begin(), aov.pixels.end()))
            << aov.name;
}

TEST(ExrReader, AFileThatIsNoNimbusExrIsAnInputErrorNamingIt)
{
    test::TempDir dir;
    std::ofstream(dir / "junk.exr") << "not an image";
    try {
        readExr(dir / "junk.exr");
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("junk.exr"), std::string::npos) << e.what();
    }
    EXPECT_THROW(readExr(dir / "missing.exr"), InputError);
}
