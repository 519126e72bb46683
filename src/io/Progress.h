// Progress.h: a render's progress on stderr, and the hook the C ABI uses for progress and cancel.
//
// On a terminal: one bar redrawn in place with '\r' (percent, elapsed, ETA). Otherwise (farm
// logs, CI; issue 16, item 6): one line per 5% step in a fixed form a farm's log parser can rely
// on (docs/farm.md, "Progress in logs"):
//   nimbus: progress 45% frame 7 elapsed 12.3s eta 15s
// advance() is called from every worker thread, so it is an atomic add; drawing and the callback
// run at most ~10 times a second (and at every step), from whichever thread gets there first,
// never two at once.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>

namespace nimbus {

// Receives the fraction done in [0, 1]; returns false to cancel the render. Called from a worker
// thread, never concurrently with itself; it must not throw.
using ProgressCallback = std::function<bool(float fraction)>;

struct ProgressOptions {
    bool quiet = false;         // print nothing; the callback still runs
    ProgressCallback callback;  // optional
    int frame = 1;              // the frame the lines off a terminal name (render.frame, --frame)
};

class Progress {
public:
    // `total` units of work (tiles, sample passes); `label` starts every line ("render").
    Progress(std::string label, size_t total, ProgressOptions options = {});
    ~Progress();  // ends a half-drawn bar with a newline so the next line starts clean

    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    // Records `n` more units done. Thread-safe. Returns false once the callback has cancelled:
    // the caller stops handing out work.
    bool advance(size_t n = 1);

    // Prints the final line (100% and the total time, or where it was cancelled) and reports the
    // final fraction to the callback. Later calls do nothing.
    void finish();

    bool cancelled() const { return mCancelled.load(std::memory_order_relaxed); }

    // Silences every Progress in the process (tests, embedding applications); callbacks still run.
    static void setQuiet(bool quiet);

private:
    using Clock = std::chrono::steady_clock;

    void update(bool final);  // draws and calls back; mDrawMutex held
    double elapsedSeconds() const;

    const std::string mLabel;
    const size_t mTotal;
    const ProgressCallback mCallback;
    const bool mQuiet;
    const bool mTerminal;
    const int mFrame;
    const Clock::time_point mStart;

    std::atomic<size_t> mDone{0};
    std::atomic<bool> mCancelled{false};
    std::atomic<long long> mNextUpdateNs{0};  // since mStart: redraws are rate-limited
    std::atomic<int> mNextStep{1};            // the next step (10% on a terminal, 5% off it) to report

    std::mutex mDrawMutex;
    bool mFinished = false;
    bool mBarOpen = false;  // a bar is on screen without its newline
    size_t mBarLength = 0;  // characters of the last bar, to blank a shorter redraw
};

}  // namespace nimbus
