#include "AtomicFile.h"

#include "TempFiles.h"
#include "core/Error.h"

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <system_error>
#include <utility>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

std::string inQuotes(const std::string& path)
{
    return "'" + path + "'";
}

// A suffix no other writer uses: 48 random bits separate processes, threads and hosts writing
// into the same shared directory.
std::string uniqueSuffix()
{
    std::random_device device;
    std::uniform_int_distribution<unsigned long long> dist;
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, ".nimbus-tmp-%012llx", dist(device) & 0xffffffffffffull);
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

std::string kindOf(mode_t mode)
{
    static const std::pair<mode_t, const char*> kinds[] = {
        {S_IFREG, ""},       {S_IFDIR, "a directory"}, {S_IFCHR, "a character device"}, {S_IFBLK, "a block device"},
        {S_IFIFO, "a FIFO"}, {S_IFSOCK, "a socket"}};
    for (const auto& [type, name] : kinds)
        if ((mode & S_IFMT) == type)
            return name;
    return "not a regular file";
}

}  // namespace

std::string followSymlinks(const std::string& path)
{
    fs::path p(path);
    for (int hops = 0; hops <= 40; ++hops) {
        struct stat st;
        if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode))
            return p.string();
        std::error_code ec;
        const fs::path link = fs::read_symlink(p, ec);
        if (ec)
            return p.string();
        p = link.is_absolute() ? link : (p.parent_path() / link).lexically_normal();
    }
    throw Error("cannot write " + inQuotes(path) + ": too many levels of symbolic links");
}

std::string nonRegularKind(const std::string& path)
{
    struct stat st;
    if (::stat(path.c_str(), &st) != 0)
        return "";
    return kindOf(st.st_mode);
}

AtomicFile::AtomicFile(std::string target) : mTarget(std::move(target))
{
    if (mTarget.empty())
        throw InputError("cannot write a file with an empty path");
    mResolved = followSymlinks(mTarget);
    const std::string kind = nonRegularKind(mResolved);
    if (!kind.empty())
        throw InputError("cannot write " + inQuotes(mTarget) + ": it is " + kind +
                         " (nimbus only replaces regular files)");
    const fs::path path(mResolved);
    std::error_code ec;
    const fs::path parent = path.parent_path();
    if (!parent.empty() && !fs::is_directory(parent, ec)) {
        fs::create_directories(parent, ec);
        if (ec)
            throw Error("cannot write " + inQuotes(mTarget) + ": cannot create directory " + inQuotes(parent.string()) +
                        ": " + ec.message());
    }
    mTemp = (parent / ("." + path.filename().string() + uniqueSuffix())).string();
    mSlot = registerTempFile(mTemp.c_str());
}

AtomicFile::~AtomicFile()
{
    discard();
}

std::FILE* AtomicFile::stream()
{
    if (mDone)
        throw Error("cannot write " + inQuotes(mTarget) + ": the temporary file was already discarded");
    if (!mStream) {
        mStream = std::fopen(mTemp.c_str(), "wb");
        if (!mStream)
            throw Error("cannot write " + inQuotes(mTarget) + ": cannot create " + inQuotes(mTemp) + ": " +
                        std::strerror(errno));
    }
    return mStream;
}

void AtomicFile::discard()
{
    if (mDone)
        return;
    mDone = true;
    if (mStream)
        std::fclose(mStream);
    mStream = nullptr;
    std::error_code ec;
    fs::remove(mTemp, ec);  // the writer may never have created it
    unregisterTempFile(mSlot);
    mSlot = -1;
}

void AtomicFile::commit()
{
    if (mDone)
        throw Error("cannot write " + inQuotes(mTarget) + ": the temporary file was already discarded");
    auto fail = [&](const std::string& what) {
        const std::string reason = std::strerror(errno);
        discard();
        return Error("cannot write " + inQuotes(mTarget) + ": " + what + ": " + reason);
    };
    if (mStream) {
        // A write error sticks to the stream; the last buffer reaches the disk in fclose.
        const bool failed = std::ferror(mStream) != 0;
        const int savedErrno = errno;
        const bool closeFailed = std::fclose(mStream) != 0;
        mStream = nullptr;
        if (failed || closeFailed) {
            if (!closeFailed)
                errno = savedErrno ? savedErrno : EIO;
            throw fail("cannot write " + inQuotes(mTemp));
        }
    }
    if (!syncPath(mTemp, false))
        throw fail("cannot flush " + inQuotes(mTemp));
    // The file replaced keeps its permissions, and as root its owner: checked again here, since
    // the target may have changed while the render ran.
    struct stat st;
    if (::lstat(mResolved.c_str(), &st) == 0) {
        const std::string kind = kindOf(st.st_mode);
        if (!kind.empty()) {
            discard();
            throw InputError("cannot write " + inQuotes(mTarget) + ": it is " + kind +
                             " (nimbus only replaces regular files)");
        }
        if (::chmod(mTemp.c_str(), st.st_mode & 07777) != 0)
            throw fail("cannot give " + inQuotes(mTemp) + " the mode of the file it replaces");
        if (::geteuid() == 0 && ::chown(mTemp.c_str(), st.st_uid, st.st_gid) != 0)
            throw fail("cannot give " + inQuotes(mTemp) + " the owner of the file it replaces");
    }
    if (std::rename(mTemp.c_str(), mResolved.c_str()) != 0)
        throw fail("cannot rename " + inQuotes(mTemp) + " over " + inQuotes(mResolved));
    mDone = true;
    unregisterTempFile(mSlot);
    mSlot = -1;
    // The rename is durable once the directory entry is; some filesystems cannot fsync a
    // directory (EINVAL), and the file is complete either way, so a failure here is not an error.
    fs::path parent = fs::path(mResolved).parent_path();
    syncPath(parent.empty() ? std::string(".") : parent.string(), true);
}

}  // namespace nimbus
