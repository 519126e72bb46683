// Frame tokens (FrameTokens.h, docs/sequences.md): every spelling and padding, negative and
// large frames, tokens in directory names, paths without tokens, and the scene's paths.
#include "core/Error.h"
#include "scene/FrameTokens.h"
#include "scene/SceneJson.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <climits>

namespace nimbus {
namespace {

TEST(FrameTokens, DollarFIsUnpadded)
{
    EXPECT_EQ(expandFrameTokens("smoke.$F.vdb", 7), "smoke.7.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F.vdb", 240), "smoke.240.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F.vdb", 0), "smoke.0.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F", 12), "smoke.12");  // at the end of the path
    EXPECT_EQ(expandFrameTokens("$F", 3), "3");
}

TEST(FrameTokens, DollarFWithDigitsPads)
{
    EXPECT_EQ(expandFrameTokens("smoke.$F4.vdb", 7), "smoke.0007.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F4.vdb", 240), "smoke.0240.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F2.vdb", 7), "smoke.07.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F3.vdb", 7), "smoke.007.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F6.vdb", 42), "smoke.000042.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F1.vdb", 42), "smoke.42.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F0.vdb", 42), "smoke.42.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.$F10.vdb", 42), "smoke.0000000042.vdb");  // two digits: width 10
    EXPECT_EQ(expandFrameTokens("smoke.$F4", 9), "smoke.0009");
}

TEST(FrameTokens, HashesPadToTheirCount)
{
    EXPECT_EQ(expandFrameTokens("smoke.#.vdb", 7), "smoke.7.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.##.vdb", 7), "smoke.07.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.###.vdb", 7), "smoke.007.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.####.vdb", 7), "smoke.0007.vdb");
    EXPECT_EQ(expandFrameTokens("smoke.######.vdb", 123), "smoke.000123.vdb");
    EXPECT_EQ(expandFrameTokens("####", 5), "0005");
}

TEST(FrameTokens, NegativeFramesCountTheSignInTheWidth)
{
    // Houdini's padzero: the width is of the whole string, the minus sign included.
    EXPECT_EQ(expandFrameTokens("s.$F4.vdb", -5), "s.-005.vdb");
    EXPECT_EQ(expandFrameTokens("s.####.vdb", -5), "s.-005.vdb");
    EXPECT_EQ(expandFrameTokens("s.$F.vdb", -5), "s.-5.vdb");
    EXPECT_EQ(expandFrameTokens("s.$F2.vdb", -5), "s.-5.vdb");
    EXPECT_EQ(expandFrameTokens("s.$F4.vdb", -1234), "s.-1234.vdb");  // wider than the width: whole
    EXPECT_EQ(padFrame(-5, 4), "-005");
    EXPECT_EQ(padFrame(-12, 6), "-00012");
}

TEST(FrameTokens, LargeFramesAreNeverTruncated)
{
    EXPECT_EQ(expandFrameTokens("s.$F4.vdb", 12345), "s.12345.vdb");
    EXPECT_EQ(expandFrameTokens("s.####.vdb", 1234567), "s.1234567.vdb");
    EXPECT_EQ(expandFrameTokens("s.$F.vdb", INT_MAX), "s.2147483647.vdb");
    EXPECT_EQ(expandFrameTokens("s.$F4.vdb", INT_MIN), "s.-2147483648.vdb");
    EXPECT_EQ(padFrame(LLONG_MIN, 4), "-9223372036854775808");
}

TEST(FrameTokens, WidthIsCapped)
{
    EXPECT_EQ(expandFrameTokens("s.$F99999999999.vdb", 1), "s." + std::string(kMaxFramePadding - 1, '0') + "1.vdb");
    EXPECT_EQ(expandFrameTokens("s." + std::string(40, '#'), 1), "s." + std::string(kMaxFramePadding - 1, '0') + "1");
}

TEST(FrameTokens, TokensInDirectoryNames)
{
    EXPECT_EQ(expandFrameTokens("cache/$F4/smoke.vdb", 12), "cache/0012/smoke.vdb");
    EXPECT_EQ(expandFrameTokens("/shots/f####/smoke.$F4.vdb", 12), "/shots/f0012/smoke.0012.vdb");
    EXPECT_EQ(expandFrameTokens("out/frame_$F/beauty.####.exr", 3), "out/frame_3/beauty.0003.exr");
}

TEST(FrameTokens, SeveralTokensAndSpellingsInOnePath)
{
    EXPECT_EQ(expandFrameTokens("a$F-b$F3-c##-d$F", 4), "a4-b004-c04-d4");
}

TEST(FrameTokens, PathsWithoutTokensAreUnchanged)
{
    for (const char* p : {"", "smoke.vdb", "/abs/dir/smoke.0001.vdb", "$", "$f4.vdb", "a$.vdb", "F4", "$$", "cost$5"}) {
        EXPECT_EQ(expandFrameTokens(p, 17), p) << p;
        EXPECT_FALSE(hasFrameTokens(p)) << p;
    }
}

TEST(FrameTokens, OtherDollarVariablesAreNotFrames)
{
    // $FPS, $FSTART, $FEND are Houdini's other variables; a directory named $Fx is not a frame.
    for (const char* p : {"$FPS.vdb", "$FSTART", "/data/$Folder/x.vdb", "$F_x"}) {
        EXPECT_EQ(expandFrameTokens(p, 17), p) << p;
        EXPECT_FALSE(hasFrameTokens(p)) << p;
    }
    EXPECT_EQ(expandFrameTokens("$F.$FPS", 2), "2.$FPS");
}

TEST(FrameTokens, HasFrameTokens)
{
    for (const char* p : {"$F", "a.$F4.b", "####", "x#", "d/$F/e"})
        EXPECT_TRUE(hasFrameTokens(p)) << p;
}

TEST(FrameTokens, SceneAtFrameReplacesEveryPath)
{
    Scene s;
    Volume v;
    v.source.type = SourceType::Vdb;
    v.source.file = "cache/smoke.$F4.vdb";
    v.shader = "shaders/v$F.ax";
    s.volumes.push_back(v);
    Geometry g;
    g.file = "geo/ground.####.obj";
    s.geometry.push_back(g);
    s.camera.holdoutDepth.file = "depth/$F3/z.exr";
    s.output.file = "out/beauty.####.exr";
    s.output.preview = "out/preview.$F.png";
    EXPECT_TRUE(sceneHasFrameTokens(s));

    const Scene f = sceneAtFrame(s, 12);
    EXPECT_EQ(f.render.frame, 12);
    EXPECT_EQ(f.volumes[0].source.file, "cache/smoke.0012.vdb");
    EXPECT_EQ(f.volumes[0].shader, "shaders/v12.ax");
    EXPECT_EQ(f.geometry[0].file, "geo/ground.0012.obj");
    EXPECT_EQ(f.camera.holdoutDepth.file, "depth/012/z.exr");
    EXPECT_EQ(f.output.file, "out/beauty.0012.exr");
    EXPECT_EQ(f.output.preview, "out/preview.12.png");
    EXPECT_FALSE(sceneHasFrameTokens(f));
    // The template is untouched.
    EXPECT_EQ(s.volumes[0].source.file, "cache/smoke.$F4.vdb");
}

TEST(FrameTokens, RenderFrameKeyRoundTrips)
{
    nlohmann::json j = sceneToJson(Scene{});
    EXPECT_EQ(j["render"]["frame"], 1);  // the default
    j["render"]["frame"] = -3;
    EXPECT_EQ(sceneFromJson(j).render.frame, -3);
    j["render"]["frame"] = 1.5;
    EXPECT_THROW(sceneFromJson(j), InputError);
}

}  // namespace
}  // namespace nimbus
