// TempDir.h: a fresh directory per test, removed afterwards, so tests can run in parallel.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <csignal>
#include <functional>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace nimbus::test {

class TempDir {
public:
    TempDir()
    {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        mPath = std::filesystem::temp_directory_path() /
                ("nimbus-io-" + std::to_string(getpid()) + "-" + info->test_suite_name() + "-" + info->name());
        std::filesystem::remove_all(mPath);
        std::filesystem::create_directories(mPath);
    }
    ~TempDir() { std::filesystem::remove_all(mPath); }

    std::string operator/(const std::string& name) const { return (mPath / name).string(); }
    const std::filesystem::path& path() const { return mPath; }

    // Entries directly in the directory: a left-over temporary file shows up here.
    size_t entryCount() const
    {
        return size_t(std::distance(std::filesystem::directory_iterator(mPath), std::filesystem::directory_iterator()));
    }

private:
    std::filesystem::path mPath;
};

inline std::string readBytes(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void writeBytes(const std::string& path, const std::string& bytes)
{
    std::ofstream(path, std::ios::binary) << bytes;
}

// A real full disk: a tmpfs of `kilobytes` mounted on a fresh directory, unmounted afterwards.
// Needs root (CAP_SYS_ADMIN); mounted() is false where it cannot be done, and the test then says
// so and skips.
class SmallTmpfs {
public:
    explicit SmallTmpfs(const std::filesystem::path& at, int kilobytes) : mPath(at)
    {
        std::filesystem::create_directories(mPath);
        const std::string options = "size=" + std::to_string(kilobytes) + "k";
        mMounted = ::mount("tmpfs", mPath.c_str(), "tmpfs", 0, options.c_str()) == 0;
    }
    ~SmallTmpfs()
    {
        if (mMounted)
            ::umount(mPath.c_str());
    }
    bool mounted() const { return mMounted; }
    std::string operator/(const std::string& name) const { return (mPath / name).string(); }

private:
    std::filesystem::path mPath;
    bool mMounted = false;
};

// Runs `body` in a forked child whose files may not grow beyond `bytes` (RLIMIT_FSIZE, SIGXFSZ
// ignored: a write past it fails with EFBIG, as a full disk fails with ENOSPC). Works without
// root. Returns the child's exit status: `body`'s return value, or 99 if it threw.
inline int inChildWithFileSizeLimit(rlim_t bytes, const std::function<int()>& body)
{
    const pid_t pid = ::fork();
    if (pid == 0) {
        std::signal(SIGXFSZ, SIG_IGN);
        struct rlimit limit = {bytes, bytes};
        ::setrlimit(RLIMIT_FSIZE, &limit);
        int code = 99;
        try {
            code = body();
        } catch (...) {
        }
        ::_exit(code);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace nimbus::test
