#include "KernelCache.h"

#include "../core/DataFiles.h"

#include "../core/Error.h"
#include "../core/Log.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <vector>

namespace fs = std::filesystem;

namespace nimbus {

namespace {

bool readFile(const fs::path& p, std::string& out)
{
    std::ifstream in(p, std::ios::binary);
    if (!in)
        return false;
    std::ostringstream s;
    s << in.rdbuf();
    out = s.str();
    return true;
}

// 128-bit key from two FNV-1a 64 streams with different offset bases (collisions are not a
// security matter here, only an accident to make vanishingly unlikely).
struct Hasher {
    uint64_t a = 0xcbf29ce484222325ull, b = 0x84222325cbf29ce4ull;
    void add(const std::string& s)
    {
        for (unsigned char c : s) {
            a = (a ^ c) * 0x100000001b3ull;
            b = (b ^ c) * 0x100000001b3ull;
        }
        // Separator, so that ("ab","c") and ("a","bc") differ.
        a = (a ^ 0xff) * 0x100000001b3ull;
        b = (b ^ 0xfe) * 0x100000001b3ull;
    }
    std::string hex() const
    {
        char buf[33];
        std::snprintf(buf, sizeof buf, "%016llx%016llx", (unsigned long long)a, (unsigned long long)b);
        return buf;
    }
};

// The first line of a build log that names an error, else its first non-empty line. Compilers
// that build from a temporary copy of the source (PoCL: ".../kcache/tempfile_XXXX.cl") have that
// path replaced by the kernel's file name.
std::string firstErrorLine(const std::string& log, const std::string& fileName)
{
    std::istringstream in(log);
    std::string line, first;
    while (std::getline(in, line)) {
        if (first.empty() && line.find_first_not_of(" \t\r") != std::string::npos)
            first = line;
        if (line.find("error") != std::string::npos) {
            first = line;
            break;
        }
    }
    if (first.empty())
        return "(empty build log)";
    size_t t = first.find("tempfile_");
    if (t != std::string::npos) {
        size_t begin = first.rfind(' ', t);
        begin = begin == std::string::npos ? 0 : begin + 1;
        size_t end = first.find(".cl", t);
        if (end != std::string::npos)
            first.replace(begin, end + 3 - begin, fileName);
    }
    return first;
}

std::string buildLog(cl_program program, cl_device_id device)
{
    size_t n = 0;
    clGetProgramBuildInfo(program, device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &n);
    std::string log(n, '\0');
    if (n)
        clGetProgramBuildInfo(program, device, CL_PROGRAM_BUILD_LOG, n, log.data(), nullptr);
    return log;
}

bool writeAtomically(const fs::path& target, const std::vector<unsigned char>& bytes)
{
    std::error_code ec;
    fs::create_directories(target.parent_path(), ec);
    std::random_device rd;
    fs::path tmp = target;
    tmp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(rd());
    {
        std::ofstream out(tmp, std::ios::binary);
        if (!out)
            return false;
        out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
        if (!out)
            return false;
    }
    fs::rename(tmp, target, ec);
    if (ec) {
        fs::remove(tmp, ec);
        return false;
    }
    return true;
}

}  // namespace

std::string kernelDirectory()
{
    if (const char* env = std::getenv("NIMBUS_KERNEL_DIR"); env && *env)
        return env;
    return dataPath(DataFile::Kernels);
}

std::string kernelCacheDirectory()
{
    if (const char* env = std::getenv("NIMBUS_CACHE_DIR"); env && *env)
        return env;
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
        return std::string(xdg) + "/nimbus/kernels";
    if (const char* home = std::getenv("HOME"); home && *home)
        return std::string(home) + "/.cache/nimbus/kernels";
    return {};
}

ProgramBuild buildProgram(const ocl::Context& ctx, const std::string& file, const std::string& options,
                          const std::string& prelude)
{
    auto start = std::chrono::steady_clock::now();
    const fs::path dir = kernelDirectory();
    const fs::path path = fs::path(file).is_absolute() ? fs::path(file) : dir / file;
    std::string source;
    if (!readFile(path, source))
        throw Error("OpenCL: cannot read kernel source " + path.string() + " (set NIMBUS_KERNEL_DIR)");

    const std::string dirText = dir.string();
    const bool quote = dirText.find(' ') != std::string::npos;
    const std::string fullOptions = "-cl-std=CL1.2 -I " + (quote ? "\"" + dirText + "\"" : dirText) + " " + options;
    const ocl::DeviceInfo& dev = ctx.device();

    Hasher h;
    h.add(NIMBUS_VERSION);
    h.add(prelude);
    h.add(source);
    std::vector<fs::path> headers;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir / "shared", ec))
        if (e.path().extension() == ".h")
            headers.push_back(e.path());
    std::sort(headers.begin(), headers.end());
    for (const fs::path& hp : headers) {
        std::string text;
        readFile(hp, text);
        h.add(hp.filename().string());
        h.add(text);
    }
    h.add(fullOptions);
    h.add(dev.platformName);
    h.add(dev.platformVersion);
    h.add(dev.name);
    h.add(dev.version);
    h.add(dev.driverVersion);

    ProgramBuild out;
    const std::string cacheDir = kernelCacheDirectory();
    const fs::path cacheFile =
        cacheDir.empty() ? fs::path() : fs::path(cacheDir) / (fs::path(file).stem().string() + "-" + h.hex() + ".bin");
    cl_device_id device = dev.device;

    // Cached binary first.
    std::string binary;
    if (!cacheFile.empty() && readFile(cacheFile, binary) && !binary.empty()) {
        const unsigned char* bytes = reinterpret_cast<const unsigned char*>(binary.data());
        size_t size = binary.size();
        cl_int status = CL_SUCCESS, err = CL_SUCCESS;
        cl_program p = clCreateProgramWithBinary(ctx.context(), 1, &device, &size, &bytes, &status, &err);
        if (err == CL_SUCCESS && status == CL_SUCCESS) {
            ocl::Program prog(p);
            if (clBuildProgram(p, 1, &device, fullOptions.c_str(), nullptr, nullptr) == CL_SUCCESS) {
                out.program = std::move(prog);
                out.fromCache = true;
                out.cacheFile = cacheFile.string();
            }
        }
        if (!out.program)
            logWarning("kernel cache entry " + cacheFile.string() + " is unusable; rebuilding it");
    }

    if (!out.program) {
        // The prelude (if any) and the file, compiled as one source.
        const char* src[2] = {prelude.c_str(), source.c_str()};
        size_t len[2] = {prelude.size(), source.size()};
        cl_int err = CL_SUCCESS;
        cl_program p = clCreateProgramWithSource(ctx.context(), 2, src, len, &err);
        ocl::check(err, "clCreateProgramWithSource");
        ocl::Program prog(p);
        err = clBuildProgram(p, 1, &device, fullOptions.c_str(), nullptr, nullptr);
        if (err != CL_SUCCESS) {
            std::string log = buildLog(p, device);
            throw Error("OpenCL: building " + path.filename().string() + " for " + dev.name +
                        " failed: " + firstErrorLine(log, path.filename().string()));
        }
        out.program = std::move(prog);
        if (!cacheFile.empty()) {
            size_t size = 0;
            if (clGetProgramInfo(p, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, nullptr) == CL_SUCCESS && size > 0) {
                std::vector<unsigned char> bytes(size);
                unsigned char* ptr = bytes.data();
                if (clGetProgramInfo(p, CL_PROGRAM_BINARIES, sizeof ptr, &ptr, nullptr) == CL_SUCCESS &&
                    writeAtomically(cacheFile, bytes))
                    out.cacheFile = cacheFile.string();
            }
        }
    }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
}

}  // namespace nimbus
