// FuzzSupport.h: what every libFuzzer harness in tests/fuzz shares (issue 18, item 5).
//
// The oracle is the CLI's contract (src/cli/main.cpp): bad input is an InputError, one line
// naming the file, and nimbus exits 2. So a harness lets InputError through and treats anything
// else as a finding: a crash or sanitizer report, a hang (libFuzzer's -timeout), memory beyond
// -rss_limit_mb / -malloc_limit_mb, and any other exception (the CLI would print "render failed"
// and exit 1 for a bad file). An empty message is a finding too. (Messages may quote control
// characters the input holds; the CLI and the C ABI print them escaped, core/OneLine.h: that
// was this harness's first finding.)
//
// The loaders read paths, not buffers (OpenVDB, Assimp and OpenImageIO pick the reader by the
// extension and read through their own streams), so each input is written to a file first, in
// /dev/shm where there is one: that is the path the CLI takes, at a few microseconds an input.
#pragma once

#include "core/Error.h"
#include "core/Log.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <typeinfo>

#include <unistd.h>

namespace nimbus::fuzz {

// A per-process scratch file that ends with `suffix` (".vdb", ".obj", ...): loaders choose the
// reader by the extension. Rewritten for every input.
inline std::string writeInput(const uint8_t* data, size_t size, const std::string& suffix)
{
    static const std::string dir = [] {
        if (access("/dev/shm", W_OK) == 0)
            return std::string("/dev/shm");
        const char* tmp = std::getenv("TMPDIR");
        return std::string(tmp && *tmp ? tmp : "/tmp");
    }();
    const std::string path = dir + "/nimbus-fuzz-" + std::to_string(getpid()) + "-input" + suffix;
    static const bool removeAtExit = [] {
        std::atexit([] {
            for (const char* s : {".json", ".vdb", ".obj", ".ply", ".exr", ".hdr"})
                std::remove((dir + "/nimbus-fuzz-" + std::to_string(getpid()) + "-input" + s).c_str());
        });
        return true;
    }();
    (void)removeAtExit;
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
        std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
        std::abort();
    }
    return path;
}

[[noreturn]] inline void finding(const std::string& what)
{
    std::fprintf(stderr, "fuzz: FINDING: %s\n", what.c_str());
    std::fflush(stderr);
    std::abort();
}

// Runs f. An InputError with a message is the expected answer to bad input; every other
// exception aborts (a finding libFuzzer saves as a crash).
template <class F>
void expectOnlyInputErrors(F&& f)
{
    try {
        f();
    } catch (const InputError& e) {
        if (!*e.what())
            finding("InputError without a message");
    } catch (const std::exception& e) {
        finding(std::string("exception other than InputError (the CLI would exit 1): ") + typeid(e).name() + ": " +
                e.what());
    } catch (...) {
        finding("exception that is not a std::exception");
    }
}

// Warnings go nowhere: libFuzzer runs millions of inputs and a warning per input would be most
// of the time spent.
inline void quietLogs()
{
    setLogSink([](LogLevel, const std::string&) {});
}

}  // namespace nimbus::fuzz
