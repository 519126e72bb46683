#include "AtomicFile.h"

#include "core/Error.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <system_error>

#include <fcntl.h>
#include <unistd.h>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

std::string inQuotes(const std::string& path) { return "'" + path + "'"; }

// A suffix no other writer uses: the pid separates processes on one host, the random part
// separates threads and hosts writing into the same shared directory.
std::string uniqueSuffix()
{
    std::random_device device;
    std::uniform_int_distribution<unsigned long long> dist;
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, ".tmp-%ld-%012llx", long(getpid()),
                  dist(device) & 0xffffffffffffull);
    return buffer;
}

// fsync a file or directory. Without it a crash shortly after the rename can leave an empty file
// under the target name on filesystems that reorder metadata and data writes.
bool syncPath(const std::string& path, bool directory)
{
    int fd = ::open(path.c_str(), directory ? (O_RDONLY | O_DIRECTORY) : O_RDONLY);
    if (fd < 0)
        return false;
    bool ok = ::fsync(fd) == 0;
    ::close(fd);
    return ok;
}

}  // namespace

AtomicFile::AtomicFile(std::string target, const std::string& extension) : mTarget(std::move(target))
{
    if (mTarget.empty())
        throw Error("cannot write a file with an empty path");
    const fs::path path(mTarget);
    std::error_code ec;
    if (fs::is_directory(path, ec))
        throw Error("cannot write " + inQuotes(mTarget) + ": it is a directory");
    const fs::path parent = path.parent_path();
    if (!parent.empty() && !fs::is_directory(parent, ec)) {
        fs::create_directories(parent, ec);
        if (ec)
            throw Error("cannot write " + inQuotes(mTarget) + ": cannot create directory " +
                        inQuotes(parent.string()) + ": " + ec.message());
    }
    mTemp = mTarget + uniqueSuffix() + extension;
}

AtomicFile::~AtomicFile() { discard(); }

void AtomicFile::discard()
{
    if (mDone)
        return;
    mDone = true;
    std::error_code ec;
    fs::remove(mTemp, ec);  // the writer may never have created it
}

void AtomicFile::commit()
{
    if (mDone)
        throw Error("cannot write " + inQuotes(mTarget) + ": the temporary file was already discarded");
    if (!syncPath(mTemp, false)) {
        const std::string reason = std::strerror(errno);
        discard();
        throw Error("cannot write " + inQuotes(mTarget) + ": cannot flush " + inQuotes(mTemp) + ": " + reason);
    }
    if (std::rename(mTemp.c_str(), mTarget.c_str()) != 0) {
        const std::string reason = std::strerror(errno);
        discard();
        throw Error("cannot write " + inQuotes(mTarget) + ": cannot rename " + inQuotes(mTemp) +
                    " over it: " + reason);
    }
    mDone = true;
    // The rename is durable once the directory entry is; some filesystems cannot fsync a
    // directory (EINVAL), and the file is complete either way, so a failure here is not an error.
    fs::path parent = fs::path(mTarget).parent_path();
    syncPath(parent.empty() ? std::string(".") : parent.string(), true);
}

}  // namespace nimbus
