#include "io/AtomicFile.h"
#include "io/TempFiles.h"

#include "TempDir.h"
#include "core/Error.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fnmatch.h>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

using namespace nimbus;
using nimbus::test::readBytes;
using nimbus::test::writeBytes;

TEST(AtomicFile, CommitReplacesTargetAndLeavesNoTemporary)
{
    test::TempDir dir;
    const std::string target = dir / "checkpoint.bin";
    writeBytes(target, "old");
    {
        AtomicFile file(target);
        EXPECT_EQ(std::filesystem::path(file.tempPath()).parent_path(), dir.path());
        writeBytes(file.tempPath(), "new");
        EXPECT_EQ(readBytes(target), "old");  // not visible until commit
        file.commit();
    }
    EXPECT_EQ(readBytes(target), "new");
    EXPECT_EQ(dir.entryCount(), 1u);
}

TEST(AtomicFile, WriterThatThrowsLeavesTargetUnchanged)
{
    test::TempDir dir;
    const std::string target = dir / "checkpoint.bin";
    writeBytes(target, "precious bytes");
    EXPECT_THROW(
        {
            AtomicFile file(target);
            writeBytes(file.tempPath(), "half a fi");
            throw std::runtime_error("writer failed mid-way");
        },
        std::runtime_error);
    EXPECT_EQ(readBytes(target), "precious bytes");
    EXPECT_EQ(dir.entryCount(), 1u);
}

TEST(AtomicFile, CreatesMissingParentDirectories)
{
    test::TempDir dir;
    const std::string target = dir / "out/shot/frame.txt";
    AtomicFile file(target);
    writeBytes(file.tempPath(), "x");
    file.commit();
    EXPECT_EQ(readBytes(target), "x");
}

TEST(AtomicFile, TwoWritersGetDistinctTemporaries)
{
    test::TempDir dir;
    AtomicFile a(dir / "f"), b(dir / "f");
    EXPECT_NE(a.tempPath(), b.tempPath());
}

TEST(AtomicFile, DirectoryTargetOrParentUnderAFileIsAnError)
{
    test::TempDir dir;
    std::filesystem::create_directories(dir / "adir");
    writeBytes(dir / "afile", "keep");
    EXPECT_THROW(AtomicFile(dir / "adir"), Error);
    try {
        AtomicFile file(dir / "afile/sub/out.bin");
        FAIL() << "expected an Error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(dir / "afile/sub/out.bin"), std::string::npos) << e.what();
    }
    EXPECT_EQ(readBytes(dir / "afile"), "keep");
}

TEST(AtomicFile, CommitWithoutATemporaryFileIsAnErrorAndTargetSurvives)
{
    test::TempDir dir;
    const std::string target = dir / "f";
    writeBytes(target, "keep");
    AtomicFile file(target);
    EXPECT_THROW(file.commit(), Error);  // the writer never created the temporary file
    EXPECT_EQ(readBytes(target), "keep");
}

// Failure 7 of issue 18: a temporary file left by a killed render was picked up by "*.exr".
TEST(AtomicFile, TemporaryNameMatchesNoOutputGlob)
{
    test::TempDir dir;
    AtomicFile file(dir / "frame.0001.exr");
    const std::string name = std::filesystem::path(file.tempPath()).filename().string();
    EXPECT_EQ(name[0], '.') << name;
    EXPECT_NE(name.find("nimbus-tmp-"), std::string::npos) << name;
    // Flags 0: as with bash's dotglob or find -name, which do not skip dot files.
    for (const char* glob : {"*.exr", "*frame.*.exr", "*.0001.exr", "*frame.0001.exr"})
        EXPECT_NE(fnmatch(glob, name.c_str(), 0), 0) << glob << " matches " << name;
}

// Failure 7: SIGINT / SIGTERM during a write remove the temporary file; the process still dies
// of the signal.
TEST(AtomicFile, SignalDuringWriteRemovesTheTemporaryFile)
{
    for (int signal : {SIGINT, SIGTERM}) {
        test::TempDir dir;
        const std::string target = dir / "out.exr";
        writeBytes(target, "earlier render");
        const pid_t pid = fork();
        if (pid == 0) {
            removeTempFilesOnSignals();
            AtomicFile file(target);
            std::fputs("half a frame", file.stream());
            std::fflush(file.stream());
            raise(signal);
            _exit(0);  // not reached
        }
        int status = 0;
        waitpid(pid, &status, 0);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << "status " << status;
        EXPECT_EQ(dir.entryCount(), 1u) << "temporary file left behind after signal " << signal;
        EXPECT_EQ(readBytes(target), "earlier render");
    }
}

// Failure 1: "-o /dev/null" as root replaced the device with a regular file.
TEST(AtomicFile, RefusesTargetsThatAreNotRegularFiles)
{
    test::TempDir dir;
    const std::string fifo = dir / "pipe.exr";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
    std::filesystem::create_directories(dir / "adir");
    std::filesystem::create_symlink("/dev/null", dir / "to_null.exr");
    for (const std::string& bad : {std::string("/dev/null"), fifo, dir / "adir", dir / "to_null.exr"}) {
        try {
            AtomicFile file(bad);
            ADD_FAILURE() << bad << " accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
        }
    }
    struct stat st;
    ASSERT_EQ(stat("/dev/null", &st), 0);
    EXPECT_TRUE(S_ISCHR(st.st_mode)) << "/dev/null is no longer a device";
    ASSERT_EQ(lstat(fifo.c_str(), &st), 0);
    EXPECT_TRUE(S_ISFIFO(st.st_mode));
}

// Failure 1: a symlink was replaced by a regular file and its target left untouched.
TEST(AtomicFile, WritesThroughSymlinksToTheirTarget)
{
    test::TempDir dir;
    std::filesystem::create_directories(dir / "store");
    writeBytes(dir / "store/real.exr", "old");
    std::filesystem::create_symlink("store/real.exr", dir / "hop.exr");  // relative, then a chain
    std::filesystem::create_symlink(dir / "hop.exr", dir / "link.exr");
    std::filesystem::create_symlink("store/new.exr", dir / "dangling.exr");
    for (const char* link : {"link.exr", "dangling.exr"}) {
        AtomicFile file(dir / link);
        EXPECT_EQ(std::filesystem::path(file.tempPath()).parent_path(), dir.path() / "store")
            << "the temporary file belongs beside the target, on its filesystem";
        std::fputs("new", file.stream());
        file.commit();
        EXPECT_TRUE(std::filesystem::is_symlink(dir / link)) << link << " is no longer a link";
        EXPECT_EQ(readBytes(dir / link), "new");
    }
    EXPECT_EQ(readBytes(dir / "store/real.exr"), "new");
    EXPECT_EQ(readBytes(dir / "store/new.exr"), "new");
    EXPECT_EQ(dir.entryCount(), 4u);  // store, hop, link, dangling: no temporary left
}

// Failure 1: mode and owner were reset to 0644 root.
TEST(AtomicFile, KeepsTheModeAndOwnerOfTheFileItReplaces)
{
    test::TempDir dir;
    const std::string target = dir / "shot.exr";
    writeBytes(target, "old");
    ASSERT_EQ(chmod(target.c_str(), 0640), 0);
    const bool root = geteuid() == 0;
    if (root) {
        ASSERT_EQ(chown(target.c_str(), 4321, 8765), 0);
    }
    AtomicFile file(target);
    std::fputs("new", file.stream());
    file.commit();
    struct stat st;
    ASSERT_EQ(stat(target.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 07777, 0640u);
    if (root) {
        EXPECT_EQ(st.st_uid, 4321u);
        EXPECT_EQ(st.st_gid, 8765u);
    }
    EXPECT_EQ(readBytes(target), "new");
}

// Failure 2: a write error must fail the commit, not rename a truncated file over a good one.
// The write error here is a real one: the child process may not grow a file past 4 KiB
// (RLIMIT_FSIZE: write() fails with EFBIG), which needs no root. IoFullDisk.* below does the
// same on a full tmpfs (ENOSPC) where the test can mount one.
TEST(AtomicFile, WriteErrorFailsCommitAndKeepsTheTarget)
{
    test::TempDir dir;
    const std::string target = dir / "checkpoint.bin";
    writeBytes(target, "good");
    const int code = test::inChildWithFileSizeLimit(4096, [&] {
        AtomicFile file(target);
        const std::string block(64 * 1024, 'x');
        std::fwrite(block.data(), 1, block.size(), file.stream());  // the writer ignores the result
        try {
            file.commit();
        } catch (const Error& e) {
            return std::string(e.what()).find(target) != std::string::npos ? 0 : 2;
        }
        return 1;  // committed a truncated file
    });
    EXPECT_EQ(code, 0) << "1: commit succeeded; 2: the error did not name the target";
    EXPECT_EQ(readBytes(target), "good");
    EXPECT_EQ(dir.entryCount(), 1u);
}
