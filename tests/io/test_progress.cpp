#include "io/Progress.h"

#include <gtest/gtest.h>

#include <sstream>
#include <thread>
#include <vector>

using namespace nimbus;

namespace {

std::vector<std::string> lines(const std::string& text)
{
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
        out.push_back(line);
    return out;
}

}  // namespace

// Tests run with stderr captured to a file, so Progress is in its plain-line mode.
TEST(Progress, PlainLinesEveryTenPercent)
{
    testing::internal::CaptureStderr();
    {
        Progress progress("render", 200);
        for (int i = 0; i < 200; ++i)
            EXPECT_TRUE(progress.advance(1));
        progress.finish();
        progress.finish();  // a second finish prints nothing
    }
    const std::vector<std::string> out = lines(testing::internal::GetCapturedStderr());
    ASSERT_EQ(out.size(), 10u);
    for (int i = 0; i < 9; ++i) {
        EXPECT_EQ(out[i].rfind("render: " + std::to_string(10 * (i + 1)) + "% (", 0), 0u) << out[i];
        EXPECT_NE(out[i].find(" s, ETA "), std::string::npos) << out[i];
        EXPECT_EQ(out[i].find('\r'), std::string::npos);
    }
    EXPECT_EQ(out[9].rfind("render: 100% (", 0), 0u) << out[9];
    EXPECT_EQ(out[9].find("ETA"), std::string::npos) << out[9];
}

TEST(Progress, QuietPrintsNothingButCallsBack)
{
    float last = -1.0f;
    testing::internal::CaptureStderr();
    {
        ProgressOptions options;
        options.quiet = true;
        options.callback = [&](float fraction) {
            last = fraction;
            return true;
        };
        Progress progress("render", 10, options);
        progress.advance(10);
        progress.finish();
    }
    Progress::setQuiet(true);
    {
        Progress progress("render", 10);
        progress.advance(10);
        progress.finish();
    }
    Progress::setQuiet(false);
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
    EXPECT_EQ(last, 1.0f);
}

TEST(Progress, CallbackCancels)
{
    ProgressOptions options;
    options.quiet = true;
    options.callback = [](float fraction) { return fraction < 0.5f; };
    Progress progress("render", 100, options);
    size_t accepted = 0;
    while (progress.advance(1))
        ++accepted;
    // The callback runs at every 10% step, so it sees 0.5 on the 50th unit at the latest.
    EXPECT_LE(accepted, 49u);
    EXPECT_TRUE(progress.cancelled());
    EXPECT_FALSE(progress.advance(1));
}

TEST(Progress, ConcurrentAdvanceReportsEveryStepOnce)
{
    testing::internal::CaptureStderr();
    {
        Progress progress("tiles", 8 * 5000);
        std::vector<std::thread> workers;
        for (int t = 0; t < 8; ++t)
            workers.emplace_back([&] {
                for (int i = 0; i < 5000; ++i)
                    progress.advance(1);
            });
        for (auto& worker : workers)
            worker.join();
        progress.finish();
    }
    const std::vector<std::string> out = lines(testing::internal::GetCapturedStderr());
    ASSERT_EQ(out.size(), 10u);
    int previous = 0;
    for (const std::string& line : out) {
        const int percent = std::stoi(line.substr(std::string("tiles: ").size()));
        EXPECT_GT(percent, previous) << line;
        previous = percent;
    }
    EXPECT_EQ(previous, 100);
}

TEST(Progress, ZeroTotalFinishesAtFullPercent)
{
    testing::internal::CaptureStderr();
    {
        Progress progress("load", 0);
        progress.finish();
    }
    EXPECT_EQ(testing::internal::GetCapturedStderr().rfind("load: 100% (", 0), 0u);
}
