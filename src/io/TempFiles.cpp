#include "TempFiles.h"

#include <atomic>
#include <climits>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>

#include <unistd.h>

namespace nimbus {

namespace {

// A handful of files are written at once (EXR, preview, a checkpoint, compare's reports); the
// table leaves room for many threads writing in one process.
constexpr int kSlots = 64;

// Slot states: free, being filled (the handler skips it), live.
enum : int { kFree = 0, kFilling = 1, kLive = 2 };

std::atomic<int> gState[kSlots];
char gPath[kSlots][PATH_MAX];

static_assert(std::atomic<int>::is_always_lock_free, "the signal handler reads the slot states");

void removeAndReraise(int signal)
{
    const int savedErrno = errno;
    for (int i = 0; i < kSlots; ++i)
        if (gState[i].load(std::memory_order_acquire) == kLive)
            ::unlink(gPath[i]);
    errno = savedErrno;
    // SA_RESETHAND restored the default action on entry: the process dies of the signal.
    ::raise(signal);
}

}  // namespace

int registerTempFile(const char* path)
{
    std::error_code ec;
    const std::string absolute = std::filesystem::absolute(path, ec).string();
    if (ec || absolute.size() + 1 > sizeof gPath[0])
        return -1;
    for (int i = 0; i < kSlots; ++i) {
        int expected = kFree;
        if (gState[i].compare_exchange_strong(expected, kFilling, std::memory_order_acq_rel)) {
            std::memcpy(gPath[i], absolute.c_str(), absolute.size() + 1);
            gState[i].store(kLive, std::memory_order_release);
            return i;
        }
    }
    return -1;
}

void unregisterTempFile(int slot)
{
    if (slot >= 0 && slot < kSlots)
        gState[slot].store(kFree, std::memory_order_release);
}

void removeTempFilesOnSignals()
{
    struct sigaction action;
    std::memset(&action, 0, sizeof action);
    action.sa_handler = removeAndReraise;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESETHAND;
    for (int signal : {SIGINT, SIGTERM, SIGHUP})
        ::sigaction(signal, &action, nullptr);
}

}  // namespace nimbus
