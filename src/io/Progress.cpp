#include "Progress.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <unistd.h>

namespace nimbus {

namespace {

std::atomic<bool> gQuiet{false};

constexpr long long kRedrawIntervalNs = 100'000'000;  // ~10 redraws a second at most
constexpr int kBarWidth = 30;
constexpr int kTerminalSteps = 10;  // on a terminal the bar is redrawn anyway; callbacks at 10% steps
constexpr int kLogSteps = 20;       // off a terminal: a line per 5%

// "12.3 s" below a minute, then "4m 05s", then "2h 07m": a render's scale.
std::string formatSeconds(double seconds)
{
    char buffer[32];
    if (seconds < 60.0)
        std::snprintf(buffer, sizeof buffer, "%.1f s", seconds);
    else if (seconds < 3600.0)
        std::snprintf(buffer, sizeof buffer, "%dm %02ds", int(seconds) / 60, int(seconds) % 60);
    else
        std::snprintf(buffer, sizeof buffer, "%dh %02dm", int(seconds) / 3600, int(seconds) / 60 % 60);
    return buffer;
}

}  // namespace

void Progress::setQuiet(bool quiet)
{
    gQuiet.store(quiet);
}

Progress::Progress(std::string label, size_t total, ProgressOptions options)
    : mLabel(std::move(label)), mTotal(total), mCallback(std::move(options.callback)),
      mQuiet(options.quiet || gQuiet.load()), mTerminal(isatty(STDERR_FILENO) == 1), mFrame(options.frame),
      mStart(Clock::now())
{
}

Progress::~Progress()
{
    std::lock_guard<std::mutex> lock(mDrawMutex);
    if (mBarOpen && !mQuiet) {
        std::fputc('\n', stderr);
        std::fflush(stderr);
    }
}

double Progress::elapsedSeconds() const
{
    return std::chrono::duration<double>(Clock::now() - mStart).count();
}

bool Progress::advance(size_t n)
{
    const size_t done = mDone.fetch_add(n, std::memory_order_relaxed) + n;
    if (mCancelled.load(std::memory_order_relaxed))
        return false;
    const size_t steps = mTerminal ? kTerminalSteps : kLogSteps;
    const int step = mTotal == 0 ? int(steps) : int(std::min(steps, done * steps / mTotal));
    const bool newStep = step >= mNextStep.load(std::memory_order_relaxed);
    const long long nowNs = std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - mStart).count();
    if (!newStep && nowNs < mNextUpdateNs.load(std::memory_order_relaxed))
        return true;
    // A step must be reported, so wait for the lock (10 or 20 times a render); a timed redraw is
    // skipped if another thread is drawing.
    std::unique_lock<std::mutex> lock(mDrawMutex, std::defer_lock);
    if (newStep)
        lock.lock();
    else if (!lock.try_lock())
        return true;
    mNextUpdateNs.store(nowNs + kRedrawIntervalNs, std::memory_order_relaxed);
    if (!mFinished)
        update(false);
    return !mCancelled.load(std::memory_order_relaxed);
}

void Progress::finish()
{
    std::lock_guard<std::mutex> lock(mDrawMutex);
    if (mFinished)
        return;
    update(true);
    mFinished = true;
}

void Progress::update(bool final)
{
    const size_t done = std::min(mDone.load(std::memory_order_relaxed), mTotal);
    const float fraction = mTotal == 0 ? 1.0f : float(double(done) / double(mTotal));
    const size_t steps = mTerminal ? kTerminalSteps : kLogSteps;
    const int step = mTotal == 0 ? int(steps) : int(done * steps / mTotal);
    const bool newStep = step >= mNextStep.load(std::memory_order_relaxed);
    if (newStep)
        mNextStep.store(step + 1, std::memory_order_relaxed);

    if (mCallback && !mCancelled.load(std::memory_order_relaxed) && !mCallback(fraction))
        mCancelled.store(true, std::memory_order_relaxed);
    if (mQuiet)
        return;

    const double elapsed = elapsedSeconds();
    const int percent = mTotal == 0 ? 100 : int(done * 100 / mTotal);
    const bool cancelled = mCancelled.load(std::memory_order_relaxed);
    if (!mTerminal) {
        // One line per step; the last one comes from finish(). The form is a contract (farm log
        // parsers, docs/farm.md): the ETA in whole seconds rounded up, "-" before the first unit
        // and once cancelled.
        if (final || (newStep && step < int(steps))) {
            std::string eta = "-";
            if (cancelled)
                eta = "-";
            else if (final)
                eta = "0s";
            else if (done > 0)
                eta = std::to_string((long long)std::ceil(elapsed * double(mTotal - done) / double(done))) + "s";
            std::fprintf(stderr, "nimbus: progress %d%% frame %d elapsed %.1fs eta %s%s\n", percent, mFrame, elapsed,
                         eta.c_str(), cancelled ? " cancelled" : "");
            std::fflush(stderr);
        }
        return;
    }
    std::string times = formatSeconds(elapsed);
    if (!final)
        times += done == 0 ? ", ETA --" : ", ETA " + formatSeconds(elapsed * double(mTotal - done) / double(done));
    const std::string status = cancelled ? " cancelled" : "";
    const int filled = int(fraction * kBarWidth);
    std::string line = "\r" + mLabel + " [" + std::string(filled, '#') + std::string(kBarWidth - filled, '.') + "] " +
                       std::to_string(percent) + "%" + status + " (" + times + ")";
    const size_t length = line.size();
    if (length < mBarLength)
        line += std::string(mBarLength - length, ' ');
    mBarLength = length;
    if (final)
        line += '\n';
    std::fputs(line.c_str(), stderr);
    std::fflush(stderr);
    mBarOpen = !final;
}

}  // namespace nimbus
