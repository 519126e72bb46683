#include "Pathtracer.h"

#include "../render/FilmLayout.h"

#include "../core/Error.h"
#include "../core/Log.h"
#include "../scene/KernelScene.h"
#include "KernelCache.h"
#include "PNanoVdbSource.h"
#include "LaunchSize.h"
#include "OpenCl.h"
#include "PathtraceScene.h"
#include "PathtraceState.h"

#include <algorithm>
#include <cstdlib>
#include <chrono>
#include <cmath>

namespace nimbus {

namespace {

using Clock = std::chrono::steady_clock;

double secondsBetween(Clock::time_point a, Clock::time_point b)
{
    return std::chrono::duration<double>(b - a).count();
}

// Russian roulette starts after this many scattering events (Skanberg sec. 6.8 uses 3).
constexpr int kRussianRouletteDepth = 3;
// Samples per pixel per pass adapt so that the longest launch of a pass lasts about
// kTargetLaunchSeconds (LaunchSize.h): short enough for progress, cancellation and GPU watchdogs,
// long enough that launch overhead is noise.
constexpr int kMaxSamplesPerPass = 64;
// max_depth 0 (unbounded, the default): Russian roulette ends the paths, and this cap only keeps
// a path from running forever. At albedo 0.9999 a path that never escapes has a mean depth of
// 10^4 scattering events, so 10^6 is passed with probability ~e^-100; an albedo-1 medium would
// need an optical radius of ~1000 for a diffusing path to need it. Paths that reach it are
// counted and reported (PathtraceStats::depthCapped, a warning).
constexpr int kSafetyMaxDepth = 1000000;
// The noise target is not trusted before this many samples per pixel: the variance of a
// heavy-tailed estimator is underestimated from few samples.
constexpr long long kMinNoiseTargetSpp = 64;

// The launch configuration for this kernel on this device (LaunchSize.h); a requested local
// size (PathtraceOptions::localSize) is checked against the kernel's limit instead.
LaunchSize launchSize(cl_kernel kernel, const ocl::DeviceInfo& device, size_t items, size_t requestedLocal)
{
    LaunchLimits d;
    d.computeUnits = size_t(std::max(1, device.computeUnits));
    clGetKernelWorkGroupInfo(kernel, device.device, CL_KERNEL_WORK_GROUP_SIZE, sizeof d.kernelWorkGroupSize,
                             &d.kernelWorkGroupSize, nullptr);
    clGetKernelWorkGroupInfo(kernel, device.device, CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE,
                             sizeof d.preferredMultiple, &d.preferredMultiple, nullptr);
    clGetDeviceInfo(device.device, CL_DEVICE_MAX_WORK_GROUP_SIZE, sizeof d.deviceMaxWorkGroupSize,
                    &d.deviceMaxWorkGroupSize, nullptr);
    size_t itemSizes[3] = {0, 0, 0};
    if (clGetDeviceInfo(device.device, CL_DEVICE_MAX_WORK_ITEM_SIZES, sizeof itemSizes, itemSizes, nullptr) ==
        CL_SUCCESS)
        d.deviceMaxWorkItemSize = itemSizes[0];
    if (requestedLocal == 0)
        return chooseLaunchSize(items, d);
    const size_t limit = maxWorkGroupSize(d);
    if (requestedLocal > limit)
        throw Error("path tracer: work-group size " + std::to_string(requestedLocal) + " exceeds the kernel's limit " +
                    std::to_string(limit) + " on " + device.name);
    LaunchSize s;
    s.local = requestedLocal;
    s.global = (items + requestedLocal - 1) / requestedLocal * requestedLocal;
    return s;
}

// The bytes of one saved path (NbPathState) as the device lays it out.
size_t pathStateBytes(const ocl::Context& cl, cl_program program)
{
    cl_int err = CL_SUCCESS;
    ocl::Kernel query(clCreateKernel(program, "nbPathStateBytes", &err));
    ocl::check(err, "clCreateKernel(nbPathStateBytes)");
    ocl::Mem out = cl.allocate(sizeof(cl_int));
    const cl_mem arg = out.get();
    ocl::check(clSetKernelArg(query.get(), 0, sizeof(cl_mem), &arg), "clSetKernelArg");
    const size_t one = 1;
    ocl::check(clEnqueueNDRangeKernel(cl.queue(), query.get(), 1, nullptr, &one, nullptr, 0, nullptr, nullptr),
               "clEnqueueNDRangeKernel(nbPathStateBytes)");
    cl_int bytes = 0;
    cl.read(out, &bytes, sizeof bytes);
    if (bytes <= 0)
        throw Error("path tracer: the device reports a path state of " + std::to_string(bytes) + " bytes");
    return size_t(bytes);
}

}  // namespace

std::vector<std::string> listOpenClDevices()
{
    std::vector<std::string> out;
    for (const ocl::DeviceInfo& d : ocl::enumerateDevices())
        out.push_back(d.describe());
    return out;
}

IntegratorTraits pathtraceTraits()
{
    IntegratorTraits t;
    t.method = Method::Pathtrace;
    t.terms = {"L0", "L1", "L2plus"};
    t.dataAovs = {"variance"};
    t.shadowMaps = false;  // next-event estimation traces shadow rays
    return t;
}

void renderPathtrace(const RenderContext& ctx, Film& film, const RenderControl& options, const PathtraceOptions& pt)
{
    if (!ctx.scene)
        throw Error("path tracer: the render context has no scene");
    const Scene& scene = *ctx.scene;
    if (film.aovs.empty())
        setupFilm(film, scene, pathtraceTraits());
    const int cropWidth = film.x1 - film.x0, cropHeight = film.y1 - film.y0;
    const long long pixelCount = (long long)std::max(0, cropWidth) * std::max(0, cropHeight);
    if (pixelCount == 0)
        return;
    if (pixelCount > 0x7fffffffLL)
        throw Error("path tracer: image too large");

    const char* densityEnv = std::getenv("NIMBUS_PATHTRACE_DENSITY");
    const bool pnanovdb = pt.pnanovdbDensity || (densityEnv && std::string(densityEnv) == "pnanovdb");
    const PathtraceScene ps = buildPathtraceScene(ctx, pnanovdb);
    const int stride = NB_ACC_STRIDE(int(ps.lights.size()));
    // The accumulator's light slots are the kernel's lights, by their AOV names.
    std::vector<std::string> lightAovs;
    for (int entry : ps.lightEntry)
        lightAovs.push_back(ctx.lights[size_t(entry)].aov);
    if (pt.keepState)
        addStateAovs(film, lightAovs);
    const bool split = pt.sampleEnd > 0;
    if (split && (pt.sampleBegin < 0 || pt.sampleEnd <= pt.sampleBegin || pt.sampleEnd > 0x7fffffffLL))
        throw Error("path tracer: sample range [" + std::to_string(pt.sampleBegin) + ", " +
                    std::to_string(pt.sampleEnd) + ") is empty or beyond 2^31 - 1");
    const long long first = split ? pt.sampleBegin : 0;  // the sample index the running means start at
    std::vector<float> resumed;
    if (pt.resumeFrom) {
        const Film& from = *pt.resumeFrom;
        if (from.x0 != film.x0 || from.x1 != film.x1 || from.y0 != film.y0 || from.y1 != film.y1 ||
            from.width != film.width || from.height != film.height)
            throw Error("path tracer: the checkpoint's data window differs from the render's");
        if (!readState(from, lightAovs, resumed))
            throw Error("path tracer: the checkpoint lacks the running estimate (state AOVs) of this scene's lights");
        if (pt.resumeSamples < 0)
            throw Error("path tracer: the checkpoint's sample count is negative");
    }

    const ocl::DeviceInfo device = ocl::selectDevice(pt.device);
    ocl::Context cl(device);
    const std::string defines = ps.defines(pt.globalMajorant);
    ProgramBuild build = buildProgram(cl, "pathtrace.cl", defines, pnanovdb ? pnanovdbOpenClSource() : std::string());
    cl_int err = CL_SUCCESS;
    ocl::Kernel kernel(clCreateKernel(build.program.get(), "nbPathtrace", &err));
    ocl::check(err, "clCreateKernel(nbPathtrace)");

    NbPtParams params{};
    params.camera = makeNbCamera(scene.camera);
    params.background[0] = ctx.background.x, params.background[1] = ctx.background.y;
    params.background[2] = ctx.background.z;
    params.width = film.width;
    params.height = film.height;
    params.x0 = film.x0;
    params.y0 = film.y0;
    params.cropWidth = cropWidth;
    params.pixelCount = int(pixelCount);
    params.seed = scene.render.seed;
    const bool unbounded = scene.render.maxDepth <= 0;
    params.maxDepth = unbounded ? kSafetyMaxDepth : scene.render.maxDepth;
    params.countDepthCap = unbounded ? 1 : 0;
    params.rrDepth = kRussianRouletteDepth;
    params.filterType = nbFilterType(scene.render.pixelFilter);
    params.filterWidth = scene.render.filterWidth;
    params.accStart = nb_uint(first);
    params.lightCount = int(ps.lights.size());
    params.volumeCount = int(ps.volumes.size());
    params.geom = ps.geometry.scene;
    params.holdoutDepthWidth = ps.holdoutDepthWidth;
    params.holdoutDepthHeight = ps.holdoutDepthHeight;
    params.holdoutDepthScale[0] = ps.holdoutDepthScale[0];
    params.holdoutDepthScale[1] = ps.holdoutDepthScale[1];
    params.envMap = ps.envMap;
    params.envLight = ps.envLight;

    ocl::Mem paramBuf = cl.allocate(sizeof params);
    ocl::Mem lightBuf = cl.upload(ps.lights);
    ocl::Mem volumeBuf = cl.upload(ps.volumes);
    // A scene of empty volumes, or the PNanoVDB variant (no tables), may leave a buffer empty:
    // one placeholder element (OpenCL has no empty buffers).
    ocl::Mem tableBuf = ps.tables.empty() ? cl.allocate(sizeof(int32_t)) : cl.upload(ps.tables);
    ocl::Mem poolBuf = ps.pools.empty() ? cl.allocate(sizeof(float)) : cl.upload(ps.pools);
    ocl::Mem majorantBuf = ps.majorants.empty() ? cl.allocate(sizeof(float)) : cl.upload(ps.majorants);
    ocl::Mem envBuf = cl.upload(ps.envData.empty() ? std::vector<float>(1, 0.0f) : ps.envData);
    ocl::Mem accBuf = cl.allocate(size_t(pixelCount) * stride * sizeof(float));
    if (!resumed.empty())
        cl.write(accBuf, resumed.data(), resumed.size() * sizeof(float));
    ocl::Mem counterBuf = cl.allocate(NB_COUNTER_COUNT * sizeof(cl_int));
    // Geometry and depth map: one placeholder element where the scene has none (OpenCL has no
    // empty buffers); the kernel compiled without them never reads it.
    auto uploadOrPlaceholder = [&](const auto& v, size_t elementBytes) {
        return v.empty() ? cl.allocate(elementBytes) : cl.upload(v);
    };
    ocl::Mem nodeBuf = uploadOrPlaceholder(ps.geometry.nodes, sizeof(NbBvhNode));
    ocl::Mem primBuf = uploadOrPlaceholder(ps.geometry.prims, sizeof(NbGeomPrim));
    ocl::Mem depthBuf = uploadOrPlaceholder(ps.holdoutDepth, sizeof(float));

    LaunchSize launch = launchSize(kernel.get(), device, size_t(pixelCount), pt.localSize);
    if (pt.runtimeWorkGroupSize)
        launch = LaunchSize{0, size_t(pixelCount)};
    const size_t global = launch.global, local = launch.local;
    // Bounded launches (LaunchSize.h): the saved paths of one range's items.
    LaunchPacer pacer(local, global, size_t(std::max(1, device.computeUnits)), pt.rangeItems, pt.stepsPerSample);
    const size_t stateBytes = pacer.maxItems * pathStateBytes(cl, build.program.get());
    ocl::Mem stateBuf = cl.allocate(stateBytes);

    const cl_mem args[] = {paramBuf.get(),   lightBuf.get(), volumeBuf.get(), tableBuf.get(), poolBuf.get(),
                           majorantBuf.get(), envBuf.get(),  accBuf.get(),    counterBuf.get(), nodeBuf.get(),
                           primBuf.get(),    depthBuf.get(), stateBuf.get()};
    for (cl_uint i = 0; i < sizeof args / sizeof args[0]; ++i)
        ocl::check(clSetKernelArg(kernel.get(), i, sizeof(cl_mem), &args[i]), "clSetKernelArg");

    // Stopping rules: spp samples if set; else the noise target; and the time limit either way.
    // An unvalidated scene with none of them renders one sample.
    const double timeLimit = scene.render.timeLimit;
    // A sample split renders its range: its length is the target, and the noise target is off.
    const double noiseTarget = split || scene.render.spp > 0 ? 0.0 : scene.render.noiseTarget;
    const long long sppTarget = split ? pt.sampleEnd - pt.sampleBegin
                                      : scene.render.spp > 0 ? scene.render.spp
                                                             : (timeLimit > 0 || noiseTarget > 0 ? 0 : 1);
    std::vector<float> acc;
    auto readAccumulator = [&] {
        acc.resize(size_t(pixelCount) * stride);
        cl.read(accBuf, acc.data(), acc.size() * sizeof(float));
    };
    auto readBack = [&](long long n) {
        readAccumulator();
        resolveState(acc, n, lightAovs, film);
    };
    double noise = INFINITY;

    const cl_int zero = 0;
    long long launches = 0, stoppedPaths = 0;
    double longestLaunch = 0;
    // One pass of n samples per pixel: launches over ranges of the items, each range until none of
    // its paths was stopped by the step budget; cancel is checked after every launch. Returns the
    // pass's longest launch.
    auto runPass = [&](int n) {
        double passLongest = 0;
        for (size_t offset = 0; offset < global;) {
            const size_t count = std::min(pacer.items, global - offset);
            params.rangeStart = int(offset);
            params.resume = 0;
            pacer.startRange();
            for (;;) {
                params.eventBudget = int(std::min<long long>(0x7fffffffLL, (long long)n * pacer.steps));
                cl.write(paramBuf, &params, sizeof params);
                cl.write(counterBuf, &zero, sizeof zero, NB_COUNTER_SUSPENDED * sizeof(cl_int));
                const auto launchStart = Clock::now();
                ocl::check(clEnqueueNDRangeKernel(cl.queue(), kernel.get(), 1, &offset, &count,
                                                  local > 0 ? &local : nullptr, 0, nullptr, nullptr),
                           "clEnqueueNDRangeKernel(nbPathtrace)");
                ocl::check(clFinish(cl.queue()), "clFinish");
                cl_int stopped = 0;
                cl.read(counterBuf, &stopped, sizeof stopped, NB_COUNTER_SUSPENDED * sizeof(cl_int));
                const double seconds = secondsBetween(launchStart, Clock::now());
                ++launches;
                stoppedPaths += stopped;
                longestLaunch = std::max(longestLaunch, seconds);
                passLongest = std::max(passLongest, seconds);
                pacer.update(seconds, stopped, params.resume == 0, n);
                if (options.cancel && options.cancel->load())
                    throw Cancelled();
                if (stopped == 0)
                    break;
                params.resume = 1;
            }
            offset += count;
        }
        return passLongest;
    };

    const auto start = Clock::now();
    auto lastCheckpoint = start;
    long long done = pt.resumeFrom ? pt.resumeSamples : 0;  // samples in the running means
    const double startSeconds = pt.resumeFrom ? std::max(0.0, pt.resumeSeconds) : 0.0;
    int passes = 0;
    int perPass = pt.samplesPerPass > 0 ? pt.samplesPerPass : 1;
    for (;;) {
        if (sppTarget > 0 && done >= sppTarget)
            break;
        if (first + done >= 0xffffffffLL)
            break;  // the RNG's sample index is 32 bits
        int n = perPass;
        if (sppTarget > 0)
            n = int(std::min<long long>(n, sppTarget - done));
        params.sampleStart = nb_uint(first + done);
        params.samples = n;
        const double passLongest = runPass(n);
        const auto now = Clock::now();
        done += n;
        ++passes;
        const double elapsed = startSeconds + secondsBetween(start, now);
        if (pt.samplesPerPass <= 0) {
            const double ideal = n * kTargetLaunchSeconds / std::max(1e-4, passLongest);
            perPass = int(std::clamp(ideal, 1.0, double(std::min(kMaxSamplesPerPass, 2 * n))));
        }
        bool converged = false;
        if (noiseTarget > 0 && done >= kMinNoiseTargetSpp) {
            readAccumulator();
            noise = stateNoiseRelMse(acc, stride, done);
            converged = noise <= noiseTarget;
        }
        if (options.progress) {
            float fraction = sppTarget > 0 ? float(double(done) / double(sppTarget)) : 0.0f;
            if (noiseTarget > 0 && std::isfinite(noise))  // relMSE falls as 1 / samples
                fraction = std::max(fraction, float(std::min(1.0, noiseTarget / noise)));
            if (timeLimit > 0)
                fraction = std::max(fraction, float(std::min(1.0, elapsed / timeLimit)));
            if (!options.progress(std::min(fraction, 1.0f)))
                throw Cancelled();
        }
        if (options.cancel && options.cancel->load())
            throw Cancelled();
        if (converged || (timeLimit > 0 && elapsed >= timeLimit))
            break;
        if (pt.checkpointSeconds > 0 && pt.onCheckpoint &&
            secondsBetween(lastCheckpoint, now) >= pt.checkpointSeconds && !(sppTarget > 0 && done >= sppTarget)) {
            readBack(done);
            film.set("pathtrace_spp", std::to_string(done));
            if (split)
                film.set("sample_start", int(first));
            pt.onCheckpoint(film);
            lastCheckpoint = Clock::now();
        }
    }
    readBack(done);
    const double renderSeconds = secondsBetween(start, Clock::now());

    cl_int counters[NB_COUNTER_COUNT] = {};
    cl.read(counterBuf, counters, sizeof counters);
    const cl_int bad = counters[NB_COUNTER_BAD_SAMPLES], capped = counters[NB_COUNTER_DEPTH_CAP];
    if (bad > 0)
        logWarning("path tracer: " + std::to_string(bad) + " non-finite path samples dropped");
    if (capped > 0)
        logWarning("path tracer: " + std::to_string(capped) + " paths reached the safety cap of " +
                   std::to_string(kSafetyMaxDepth) + " scattering events and were ended (energy lost)");

    film.set("pathtrace_spp", std::to_string(done));
    film.set("pathtrace_device", device.name);
    if (split)
        film.set("sample_start", int(first));
    if (pt.stats) {
        PathtraceStats& s = *pt.stats;
        s.samplesPerPixel = done;
        s.pathSamples = done * pixelCount;
        s.renderSeconds = renderSeconds;
        s.buildSeconds = build.seconds;
        s.kernelFromCache = build.fromCache;
        s.passes = passes;
        s.badSamples = bad;
        s.depthCapped = capped;
        s.localSize = local;
        s.workGroups = local > 0 ? global / local : 0;
        s.launches = launches;
        s.stoppedPaths = stoppedPaths;
        s.longestLaunchSeconds = longestLaunch;
        s.pathStateBytes = stateBytes;
        s.noiseRelMse = noiseTarget > 0 ? noise : 0;
        s.device = device.describe();
        s.defines = defines;
        s.geometryBuildSeconds = ps.geometry.buildSeconds;
        s.geometryBytes = ps.geometry.memoryBytes();
        s.volumeBytes = ps.volumeBytes();
    }
}

}  // namespace nimbus
