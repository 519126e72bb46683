// AtomicFile.h: write a file under a temporary name beside its target, then rename it over the
// target, so that a reader (a compositor watching the output directory, a farm's checker, a
// resumed render reading its checkpoint) sees the old file or the complete new one, never half a
// file. A failed write leaves an existing target untouched and removes the temporary file.
//
// Usage: construct, let the writer (OpenImageIO, an ofstream) write tempPath(), then commit().
// Destroying the object without commit() removes the temporary file, so an exception thrown by
// the writer cleans up on its way out.
#pragma once

#include <string>

namespace nimbus {

class AtomicFile {
public:
    // Creates the target's missing parent directories (a farm hands out paths like
    // "out/shot/frame.exr") and picks "<target>.tmp-<pid>-<random><extension>" in the same
    // directory, so the rename never crosses filesystems. `extension` (".exr", ".png") keeps the
    // temporary name's extension meaningful to writers that choose the format by it.
    // Throws Error naming the target if a parent cannot be created or the target is a directory.
    explicit AtomicFile(std::string target, const std::string& extension = "");
    ~AtomicFile();

    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    const std::string& targetPath() const { return mTarget; }
    const std::string& tempPath() const { return mTemp; }

    // Flushes the temporary file to disk and renames it over the target. Throws Error naming the
    // target (and removes the temporary file) if either step fails.
    void commit();

    // Removes the temporary file now; commit() is then an error. Safe to call twice.
    void discard();

private:
    std::string mTarget;
    std::string mTemp;
    bool mDone = false;  // committed or discarded: nothing left to clean up
};

}  // namespace nimbus
