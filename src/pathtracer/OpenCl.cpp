#include "OpenCl.h"

#include "../core/Error.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#if defined(__linux__)
#include <dlfcn.h>
#endif

namespace nimbus::ocl {

namespace {

// The ICD loader's "no platform" code (cl_khr_icd), spelled out to avoid including cl_ext.h.
constexpr cl_int CL_PLATFORM_NOT_FOUND_KHR_VALUE = -1001;

std::string platformString(cl_platform_id p, cl_platform_info what)
{
    size_t n = 0;
    if (clGetPlatformInfo(p, what, 0, nullptr, &n) != CL_SUCCESS || n == 0)
        return {};
    std::string s(n, '\0');
    clGetPlatformInfo(p, what, n, s.data(), nullptr);
    while (!s.empty() && (s.back() == '\0' || std::isspace(static_cast<unsigned char>(s.back()))))
        s.pop_back();
    return s;
}

std::string deviceString(cl_device_id d, cl_device_info what)
{
    size_t n = 0;
    if (clGetDeviceInfo(d, what, 0, nullptr, &n) != CL_SUCCESS || n == 0)
        return {};
    std::string s(n, '\0');
    clGetDeviceInfo(d, what, n, s.data(), nullptr);
    while (!s.empty() && (s.back() == '\0' || std::isspace(static_cast<unsigned char>(s.back()))))
        s.pop_back();
    return s;
}

std::string lower(std::string s)
{
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return s;
}

// nimbus links OpenVDB AX, which brings its own LLVM (libLLVM-14 on Debian 12) into the global
// symbol scope at start-up; PoCL compiles kernels with another LLVM (libLLVM-15). When the ICD
// loader dlopens PoCL normally, LLVM-15's calls bind to LLVM-14's same-named symbols and the
// kernel compiler crashes. Loading every ICD first with RTLD_DEEPBIND gives each driver's
// dependency group precedence over the global scope (RTLD_LOCAL keeps it out of everyone else's);
// the ICD loader's own dlopen then gets the already-loaded library. Set
// NIMBUS_OPENCL_NO_DEEPBIND=1 to skip this.
void isolateOpenClDrivers()
{
#if defined(__linux__) && defined(RTLD_DEEPBIND)
    static std::once_flag once;
    std::call_once(once, [] {
        if (const char* off = std::getenv("NIMBUS_OPENCL_NO_DEEPBIND"); off && *off && *off != '0')
            return;
        namespace fs = std::filesystem;
        std::vector<fs::path> icds;
        std::error_code ec;
        std::string dir = "/etc/OpenCL/vendors";
        if (const char* env = std::getenv("OCL_ICD_VENDORS"); env && *env)
            dir = env;
        if (fs::is_regular_file(dir, ec))
            icds.push_back(dir);
        else
            for (const auto& e : fs::directory_iterator(dir, ec))
                if (e.path().extension() == ".icd")
                    icds.push_back(e.path());
        for (const fs::path& icd : icds) {
            std::ifstream in(icd);
            std::string lib;
            std::getline(in, lib);
            while (!lib.empty() && std::isspace(static_cast<unsigned char>(lib.back())))
                lib.pop_back();
            if (!lib.empty())
                dlopen(lib.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND);  // failure: the loader reports it
        }
    });
#endif
}

}  // namespace

const char* errorName(cl_int err)
{
    switch (err) {
    case CL_SUCCESS: return "CL_SUCCESS";
    case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
    case CL_DEVICE_NOT_AVAILABLE: return "CL_DEVICE_NOT_AVAILABLE";
    case CL_COMPILER_NOT_AVAILABLE: return "CL_COMPILER_NOT_AVAILABLE";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
    case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_VALUE: return "CL_INVALID_VALUE";
    case CL_INVALID_PLATFORM: return "CL_INVALID_PLATFORM";
    case CL_INVALID_DEVICE: return "CL_INVALID_DEVICE";
    case CL_INVALID_CONTEXT: return "CL_INVALID_CONTEXT";
    case CL_INVALID_COMMAND_QUEUE: return "CL_INVALID_COMMAND_QUEUE";
    case CL_INVALID_MEM_OBJECT: return "CL_INVALID_MEM_OBJECT";
    case CL_INVALID_BINARY: return "CL_INVALID_BINARY";
    case CL_INVALID_BUILD_OPTIONS: return "CL_INVALID_BUILD_OPTIONS";
    case CL_INVALID_PROGRAM: return "CL_INVALID_PROGRAM";
    case CL_INVALID_PROGRAM_EXECUTABLE: return "CL_INVALID_PROGRAM_EXECUTABLE";
    case CL_INVALID_KERNEL_NAME: return "CL_INVALID_KERNEL_NAME";
    case CL_INVALID_KERNEL: return "CL_INVALID_KERNEL";
    case CL_INVALID_ARG_INDEX: return "CL_INVALID_ARG_INDEX";
    case CL_INVALID_ARG_VALUE: return "CL_INVALID_ARG_VALUE";
    case CL_INVALID_ARG_SIZE: return "CL_INVALID_ARG_SIZE";
    case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_WORK_DIMENSION: return "CL_INVALID_WORK_DIMENSION";
    case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_INVALID_WORK_ITEM_SIZE: return "CL_INVALID_WORK_ITEM_SIZE";
    case CL_INVALID_GLOBAL_OFFSET: return "CL_INVALID_GLOBAL_OFFSET";
    case CL_INVALID_BUFFER_SIZE: return "CL_INVALID_BUFFER_SIZE";
    case CL_PLATFORM_NOT_FOUND_KHR_VALUE: return "CL_PLATFORM_NOT_FOUND_KHR";
    default: return "unknown OpenCL error";
    }
}

void check(cl_int err, const char* what)
{
    if (err != CL_SUCCESS)
        throw Error(std::string("OpenCL: ") + what + " failed: " + errorName(err) + " (" + std::to_string(err) + ")");
}

std::string DeviceInfo::describe() const
{
    std::ostringstream o;
    o << index << ": " << name << " [" << type << ", " << computeUnits << " compute units, " << (globalMemBytes >> 20)
      << " MiB] on " << platformName << " (" << version << ", driver " << driverVersion << ")";
    return o.str();
}

std::vector<DeviceInfo> enumerateDevices()
{
    isolateOpenClDrivers();
    cl_uint np = 0;
    cl_int err = clGetPlatformIDs(0, nullptr, &np);
    if (err == CL_PLATFORM_NOT_FOUND_KHR_VALUE || np == 0)
        throw Error("OpenCL: no platform found (install an OpenCL driver, e.g. PoCL: apt install pocl-opencl-icd)");
    check(err, "clGetPlatformIDs");
    std::vector<cl_platform_id> platforms(np);
    check(clGetPlatformIDs(np, platforms.data(), nullptr), "clGetPlatformIDs");
    std::vector<DeviceInfo> out;
    for (cl_platform_id p : platforms) {
        cl_uint nd = 0;
        if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &nd) != CL_SUCCESS || nd == 0)
            continue;
        std::vector<cl_device_id> devices(nd);
        if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, nd, devices.data(), nullptr) != CL_SUCCESS)
            continue;
        for (cl_device_id d : devices) {
            DeviceInfo info;
            info.index = int(out.size());
            info.platform = p;
            info.device = d;
            info.platformName = platformString(p, CL_PLATFORM_NAME);
            info.platformVersion = platformString(p, CL_PLATFORM_VERSION);
            info.name = deviceString(d, CL_DEVICE_NAME);
            info.version = deviceString(d, CL_DEVICE_VERSION);
            info.driverVersion = deviceString(d, CL_DRIVER_VERSION);
            cl_device_type type = 0;
            clGetDeviceInfo(d, CL_DEVICE_TYPE, sizeof type, &type, nullptr);
            info.type = (type & CL_DEVICE_TYPE_GPU)           ? "GPU"
                        : (type & CL_DEVICE_TYPE_CPU)         ? "CPU"
                        : (type & CL_DEVICE_TYPE_ACCELERATOR) ? "accelerator"
                                                              : "other";
            cl_uint cu = 0;
            clGetDeviceInfo(d, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof cu, &cu, nullptr);
            info.computeUnits = int(cu);
            cl_ulong mem = 0;
            clGetDeviceInfo(d, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof mem, &mem, nullptr);
            info.globalMemBytes = mem;
            out.push_back(info);
        }
    }
    if (out.empty())
        throw Error("OpenCL: platforms found but no device");
    return out;
}

DeviceInfo selectDevice(const std::string& specIn)
{
    std::vector<DeviceInfo> devices = enumerateDevices();
    std::string spec = specIn;
    if (spec.empty()) {
        if (const char* env = std::getenv("NIMBUS_DEVICE"))
            spec = env;
    }
    if (spec.empty()) {
        for (const DeviceInfo& d : devices)
            if (d.type == "GPU")
                return d;
        return devices.front();
    }
    bool numeric = std::all_of(spec.begin(), spec.end(), [](unsigned char c) { return std::isdigit(c); });
    if (numeric) {
        size_t i = std::stoul(spec);
        if (i < devices.size())
            return devices[i];
    } else {
        std::string key = lower(spec);
        for (const DeviceInfo& d : devices)
            if (lower(d.platformName + " " + d.name).find(key) != std::string::npos)
                return d;
    }
    std::string list;
    for (const DeviceInfo& d : devices)
        list += (list.empty() ? "" : "; ") + d.describe();
    throw Error("OpenCL: no device matches '" + spec + "' (devices: " + list + ")");
}

Context::Context(const DeviceInfo& device) : mDevice(device)
{
    cl_int err = CL_SUCCESS;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, cl_context_properties(device.platform), 0};
    mContext = clCreateContext(props, 1, &device.device, nullptr, nullptr, &err);
    check(err, "clCreateContext");
    mQueue = clCreateCommandQueue(mContext, device.device, 0, &err);
    if (err != CL_SUCCESS) {
        clReleaseContext(mContext);
        check(err, "clCreateCommandQueue");
    }
}

Context::~Context()
{
    if (mQueue)
        clReleaseCommandQueue(mQueue);
    if (mContext)
        clReleaseContext(mContext);
}

namespace {

// Devices cap single allocations (CL_DEVICE_MAX_MEM_ALLOC_SIZE, often a quarter of the memory):
// say so in one line rather than fail with CL_INVALID_BUFFER_SIZE.
void checkAllocation(const DeviceInfo& device, size_t bytes)
{
    cl_ulong maxAlloc = 0;
    if (clGetDeviceInfo(device.device, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof maxAlloc, &maxAlloc, nullptr) ==
            CL_SUCCESS &&
        maxAlloc > 0 && bytes > maxAlloc)
        throw Error("OpenCL: a " + std::to_string(bytes >> 20) + " MiB buffer exceeds the largest allocation " +
                    std::to_string(maxAlloc >> 20) + " MiB on " + device.name +
                    " (coarser or fewer volumes, or another device)");
}

}  // namespace

Mem Context::upload(const void* data, size_t bytes) const
{
    checkAllocation(mDevice, bytes);
    cl_int err = CL_SUCCESS;
    const unsigned char pad[16] = {};
    if (bytes == 0 || !data) {
        data = pad;
        bytes = sizeof pad;
    }
    cl_mem m = clCreateBuffer(mContext, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, const_cast<void*>(data), &err);
    check(err, "clCreateBuffer");
    return Mem(m);
}

Mem Context::allocate(size_t bytes) const
{
    checkAllocation(mDevice, bytes);
    cl_int err = CL_SUCCESS;
    bytes = std::max<size_t>(bytes, 16);
    cl_mem m = clCreateBuffer(mContext, CL_MEM_READ_WRITE, bytes, nullptr, &err);
    check(err, "clCreateBuffer");
    Mem out(m);
    const cl_uint zero = 0;  // bytes is a multiple of 4 for every buffer nimbus allocates
    if (bytes % sizeof zero == 0) {
        check(clEnqueueFillBuffer(mQueue, m, &zero, sizeof zero, 0, bytes, 0, nullptr, nullptr), "clEnqueueFillBuffer");
        check(clFinish(mQueue), "clFinish");
    } else {
        std::vector<unsigned char> zeros(bytes, 0);
        write(out, zeros.data(), bytes);
    }
    return out;
}

void Context::read(const Mem& m, void* dst, size_t bytes, size_t offset) const
{
    check(clEnqueueReadBuffer(mQueue, m.get(), CL_TRUE, offset, bytes, dst, 0, nullptr, nullptr), "clEnqueueReadBuffer");
}

void Context::write(const Mem& m, const void* src, size_t bytes, size_t offset) const
{
    check(clEnqueueWriteBuffer(mQueue, m.get(), CL_TRUE, offset, bytes, src, 0, nullptr, nullptr), "clEnqueueWriteBuffer");
}

}  // namespace nimbus::ocl
