// oneLine (src/core/OneLine.h): a message quoting user text stays one line. Control bytes become
// escapes, UTF-8 passes as it is (or as \xNN with asciiOnly, for lines of binary files), and an
// escaped message is left as it is.
#include "core/OneLine.h"

#include <gtest/gtest.h>

using nimbus::oneLine;

TEST(OneLine, ControlBytesAreEscapedAndUtf8Kept)
{
    EXPECT_EQ(oneLine("a\nb\rc\td"), "a\\nb\\rc\\td");
    EXPECT_EQ(oneLine(std::string("a\0b\x7f", 4)), "a\\x00b\\x7f");
    EXPECT_EQ(oneLine("caf\xc3\xa9"), "caf\xc3\xa9");
    EXPECT_EQ(oneLine(oneLine("x\ny")), oneLine("x\ny"));
}

TEST(OneLine, AsciiOnlyEscapesBytesAboveAscii)
{
    EXPECT_EQ(oneLine("caf\xc3\xa9", true), "caf\\xc3\\xa9");
    EXPECT_EQ(oneLine(std::string("ply\0\xff", 5), true), "ply\\x00\\xff");
    EXPECT_EQ(oneLine("plain ~ text", true), "plain ~ text");
}
