#include "io/Progress.h"

#include <gtest/gtest.h>

#include <regex>
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

// The farm-log grammar of docs/farm.md, "Progress in logs".
const std::regex kLine(R"(^nimbus: progress (\d{1,3})% frame (-?\d+) elapsed (\d+\.\d)s eta (\d+s|-)( cancelled)?$)");

// Tests run with stderr captured to a file, so Progress is in its plain-line mode.
TEST(Progress, PlainLinesEveryFivePercent)
{
    testing::internal::CaptureStderr();
    {
        Progress progress("render", 200, ProgressOptions{false, {}, 7});
        for (int i = 0; i < 200; ++i)
            EXPECT_TRUE(progress.advance(1));
        progress.finish();
        progress.finish();  // a second finish prints nothing
    }
    const std::vector<std::string> out = lines(testing::internal::GetCapturedStderr());
    ASSERT_EQ(out.size(), 20u);
    for (int i = 0; i < 20; ++i) {
        std::smatch m;
        ASSERT_TRUE(std::regex_match(out[i], m, kLine)) << out[i];
        EXPECT_EQ(m[1].str(), std::to_string(5 * (i + 1))) << out[i];
        EXPECT_EQ(m[2].str(), "7") << out[i];
        EXPECT_NE(m[4].str(), "-") << out[i];
    }
    EXPECT_EQ(out[19].substr(out[19].size() - 6), "eta 0s") << out[19];
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
    ASSERT_EQ(out.size(), 20u);
    int previous = 0;
    for (const std::string& line : out) {
        std::smatch m;
        ASSERT_TRUE(std::regex_match(line, m, kLine)) << line;
        const int percent = std::stoi(m[1].str());
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
    EXPECT_EQ(testing::internal::GetCapturedStderr().rfind("nimbus: progress 100% frame 1 elapsed ", 0), 0u);
}
