#include "io/AtomicFile.h"

#include "TempDir.h"
#include "core/Error.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

using namespace nimbus;
using nimbus::test::readBytes;
using nimbus::test::writeBytes;

TEST(AtomicFile, CommitReplacesTargetAndLeavesNoTemporary)
{
    test::TempDir dir;
    const std::string target = dir / "checkpoint.bin";
    writeBytes(target, "old");
    {
        AtomicFile file(target, ".bin");
        EXPECT_EQ(std::filesystem::path(file.tempPath()).parent_path(), dir.path());
        EXPECT_EQ(std::filesystem::path(file.tempPath()).extension(), ".bin");
        EXPECT_NE(file.tempPath().find(".tmp-"), std::string::npos);
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
