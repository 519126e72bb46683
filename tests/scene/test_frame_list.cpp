// The --frames spelling (FrameList.h): frames, ranges, stepped ranges, lists, and what is refused.
#include "core/Error.h"
#include "scene/FrameList.h"

#include <gtest/gtest.h>

namespace nimbus {
namespace {

using Frames = std::vector<int>;

TEST(FrameList, Spellings)
{
    EXPECT_EQ(parseFrameList("7"), Frames({7}));
    EXPECT_EQ(parseFrameList("1-4"), Frames({1, 2, 3, 4}));
    EXPECT_EQ(parseFrameList("1-9x2"), Frames({1, 3, 5, 7, 9}));
    EXPECT_EQ(parseFrameList("1-10x4"), Frames({1, 5, 9}));  // B itself only when on the step
    EXPECT_EQ(parseFrameList("1,5,9-12"), Frames({1, 5, 9, 10, 11, 12}));
    EXPECT_EQ(parseFrameList("3-3"), Frames({3}));
    EXPECT_EQ(parseFrameList("10,2"), Frames({10, 2}));  // the order given
    EXPECT_EQ(parseFrameList("-2-1"), Frames({-2, -1, 0, 1}));
    EXPECT_EQ(parseFrameList("-5--3"), Frames({-5, -4, -3}));
    EXPECT_EQ(parseFrameList("1-240").size(), 240u);
    EXPECT_EQ(parseFrameList("1-240x2").size(), 120u);
}

TEST(FrameList, BadSpecsAreInputErrors)
{
    for (const char* bad :
         {"",      ",",      "1,",   ",1",    "1-",  "-",     "a",           "1-a",          "1..3", "3-1",
          "1-5x0", "1-5x-1", "1-5x", "1 - 3", "1,1", "1-3,2", "99999999999", "1-2000000000", "1x2",  "1-3y2"}) {
        EXPECT_THROW(parseFrameList(bad), InputError) << "'" << bad << "'";
    }
    try {
        parseFrameList("3-1");
        FAIL();
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("bad frame list '3-1'"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace nimbus
