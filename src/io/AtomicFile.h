// AtomicFile.h: write a file under a temporary name beside its target, then rename it over the
// target, so that a reader (a compositor watching the output directory, a farm's checker, a
// resumed render reading its checkpoint) sees the old file or the complete new one, never half a
// file. A failed write leaves an existing target untouched and removes the temporary file.
//
// What "the target" is (docs/output.md, "Safe outputs"):
// - a symlink is followed to the file it names (chains too), and that file is replaced: the link
//   stays a link, and the temporary file sits in the directory of the link's target, so the
//   rename never crosses filesystems;
// - an existing target must be a regular file: a directory, device (/dev/null), FIFO or socket is
//   refused before anything is written (InputError), never replaced by a file;
// - an existing target keeps its permission bits, and its owner and group when running as root
//   (a farm's render user writing over a shot's files must not take them over).
//
// The temporary name is "<dir>/.<name>.nimbus-tmp-<random>": hidden, and ending in no extension,
// so no output glob (*.exr, frame.*.exr, even with dotglob or find -name) matches it. Live
// temporary names are registered (TempFiles.h), so the CLI removes them on SIGINT and SIGTERM.
//
// Usage: construct, let the writer write to stream() (OpenImageIO through an IOFile proxy,
// fwrite), then commit(). commit() checks the stream's own error state and fclose's result, so a
// write the writer failed to report (a full disk seen only when the last buffer is flushed) still
// fails the commit instead of renaming a truncated file over a good one. A writer that opens
// tempPath() itself must choose its format by name, not by the name's extension. Destroying the
// object without commit() removes the temporary file, so an exception thrown by the writer cleans
// up on its way out.
#pragma once

#include <cstdio>
#include <string>

namespace nimbus {

class AtomicFile {
public:
    // Resolves symlinks, checks that an existing target is a regular file (else InputError
    // naming the target and what it is), creates the target's missing parent directories (a farm
    // hands out paths like "out/shot/frame.exr") and picks the temporary name. Throws Error
    // naming the target if a parent cannot be created.
    explicit AtomicFile(std::string target);
    ~AtomicFile();

    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    // The path as given, and the file actually replaced (the end of its symlink chain).
    const std::string& targetPath() const { return mTarget; }
    const std::string& resolvedPath() const { return mResolved; }
    const std::string& tempPath() const { return mTemp; }

    // The temporary file opened for writing ("wb"), owned by this object (commit and discard close
    // it). Throws Error naming the target if it cannot be created.
    std::FILE* stream();

    // Flushes the temporary file to disk, gives it the existing target's mode (and owner, as
    // root) and renames it over the resolved target. Throws Error naming the target (and removes
    // the temporary file) if a step fails.
    void commit();

    // Removes the temporary file now; commit() is then an error. Safe to call twice.
    void discard();

private:
    std::string mTarget;
    std::string mResolved;
    std::string mTemp;
    std::FILE* mStream = nullptr;
    int mSlot = -1;      // the temporary name's entry in the signal-cleanup registry
    bool mDone = false;  // committed or discarded: nothing left to clean up
};

// The end of `path`'s symlink chain (relative links resolved against their own directory); the
// path itself when it is not a link or does not exist. A dangling link gives the missing file it
// names. Throws Error on a loop (more than 40 links).
std::string followSymlinks(const std::string& path);

// What kind of file sits at `path` after following symlinks: "" for a regular file or nothing,
// else "a directory", "a character device", "a block device", "a FIFO", "a socket".
std::string nonRegularKind(const std::string& path);

}  // namespace nimbus
