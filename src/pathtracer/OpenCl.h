// OpenCl.h: the OpenCL runtime as the path tracer uses it: device discovery and selection,
// a context with one in-order queue, and owning handles. Every failure throws nimbus::Error
// with one line naming the call and the error (STYLE rule 8); nothing here aborts.
//
// The C API (OpenCL 1.2, which PoCL and every GPU vendor ship) rather than the C++ bindings:
// the handful of calls needed do not justify a second header dialect.
#pragma once

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>

#include <string>
#include <vector>

namespace nimbus::ocl {

struct DeviceInfo {
    int index = -1;  // position in enumerateDevices(), over all platforms
    cl_platform_id platform = nullptr;
    cl_device_id device = nullptr;
    std::string platformName, platformVersion;
    std::string name, version, driverVersion, type;
    int computeUnits = 0;
    unsigned long long globalMemBytes = 0;
    std::string describe() const;  // one line for `nimbus devices` and logs
};

// Throws Error("...no OpenCL platform...") when the ICD loader finds none.
std::vector<DeviceInfo> enumerateDevices();

// `spec`: empty (the NIMBUS_DEVICE environment variable if set, else the first GPU, else the
// first device), a number (index in enumerateDevices()), or a case-insensitive substring of
// "platform device". Throws Error listing the devices when nothing matches.
DeviceInfo selectDevice(const std::string& spec);

const char* errorName(cl_int err);
void check(cl_int err, const char* what);

// Owning handles (move-only).
template <class T, cl_int (*Release)(T)>
class Handle {
public:
    Handle() = default;
    explicit Handle(T h) : mH(h) {}
    Handle(Handle&& o) noexcept : mH(o.mH) { o.mH = nullptr; }
    Handle& operator=(Handle&& o) noexcept
    {
        if (this != &o) {
            reset();
            mH = o.mH;
            o.mH = nullptr;
        }
        return *this;
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    ~Handle() { reset(); }
    void reset()
    {
        if (mH)
            Release(mH);
        mH = nullptr;
    }
    T get() const { return mH; }
    explicit operator bool() const { return mH != nullptr; }

private:
    T mH = nullptr;
};

using Mem = Handle<cl_mem, clReleaseMemObject>;
using Program = Handle<cl_program, clReleaseProgram>;
using Kernel = Handle<cl_kernel, clReleaseKernel>;

class Context {
public:
    explicit Context(const DeviceInfo& device);
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    cl_context context() const { return mContext; }
    cl_command_queue queue() const { return mQueue; }
    const DeviceInfo& device() const { return mDevice; }

    // A read-only buffer holding `bytes` copied from `data` (at least 4 bytes: OpenCL has no
    // empty buffers, and kernels may be handed a buffer they never read).
    Mem upload(const void* data, size_t bytes) const;
    Mem allocate(size_t bytes) const;  // read-write, zero-filled
    template <class T, class A>
    Mem upload(const std::vector<T, A>& v) const
    {
        return upload(v.data(), v.size() * sizeof(T));
    }
    // Blocking; `offset` bytes into the buffer.
    void read(const Mem& m, void* dst, size_t bytes, size_t offset = 0) const;
    void write(const Mem& m, const void* src, size_t bytes, size_t offset = 0) const;

private:
    DeviceInfo mDevice;
    cl_context mContext = nullptr;
    cl_command_queue mQueue = nullptr;
};

}  // namespace nimbus::ocl
