// Pathtracer.h: "method": "pathtrace", nimbus's unbiased reference (kernels/pathtrace.cl,
// docs/pathtracer.md). The host side: device selection, scene upload, progressive rendering in
// launches of a few samples per pixel with a running estimate (Skanberg sec. 6.9), stopping
// rules, checkpoints and the AOVs by scattering order.
#pragma once

#include "../render/Film.h"
#include "../render/Integrator.h"
#include "../render/RenderContext.h"

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace nimbus {

// What a render did, for logs, benchmarks and tests.
struct PathtraceStats {
    long long samplesPerPixel = 0;
    long long pathSamples = 0;  // camera paths traced (pixels x samples)
    double renderSeconds = 0;   // kernel launches and read-backs, not the build or the upload
    double buildSeconds = 0;    // kernel build or cache load
    bool kernelFromCache = false;
    int passes = 0;
    long long badSamples = 0;   // non-finite samples dropped (should be 0)
    long long depthCapped = 0;  // paths ended by the safety cap of an unbounded render (should be 0)
    size_t localSize = 0;       // the launch's work-group size (0: the runtime chose)
    size_t workGroups = 0;      // work-groups per pass over the image (0: the runtime chose)
    long long launches = 0;     // kernel launches (a pass is one or more: LaunchSize.h)
    long long stoppedPaths = 0; // paths a launch's step budget stopped, continued by the next
    double longestLaunchSeconds = 0;
    size_t pathStateBytes = 0;  // the saved paths' buffer on the device (one range's items)
    double noiseRelMse = 0;     // with a noise target: the beauty's relMSE from its variance at the end
                                // (infinite below 64 spp, where it is not measured)
    std::string device;
    std::string defines;
    double geometryBuildSeconds = 0;  // the kernel's BVH (KernelBvh.h): Embree's builder and flattening
    size_t geometryBytes = 0;         // its nodes and primitives on the device
    size_t volumeBytes = 0;           // the volumes' buffers on the device: brick tables, pools (or
                                      // NanoVDB grids), slot majorants, descriptors
    double pathsPerSecond() const { return renderSeconds > 0 ? double(pathSamples) / renderSeconds : 0.0; }
};

struct PathtraceOptions {
    // OpenCL device: "" (the NIMBUS_DEVICE environment variable, else the first GPU, else the
    // first device), an index into listOpenClDevices(), or a substring of its name.
    std::string device;
    // When both are set, onCheckpoint receives the running estimate at most every
    // checkpointSeconds (after the launch that crosses the interval). The CLI writes its EXR.
    double checkpointSeconds = 0;
    std::function<void(const Film&)> onCheckpoint;
    // A sample split (docs/farm.md): sampleEnd > 0 renders the sample indices [sampleBegin,
    // sampleEnd) of the seed's sequence per pixel instead of scene.render.spp (the time limit still
    // applies, the noise target not), its running means counting from sampleBegin; the film gets
    // "sample_start". Splits of one seed merge into exactly the samples of one longer render.
    long long sampleBegin = 0, sampleEnd = 0;
    // Keep the running estimate in the film as its state AOVs (PathtraceState.h): what a
    // checkpoint needs to resume and a sample split to merge.
    bool keepState = false;
    // Resume (docs/farm.md): a checkpoint's film, with its state AOVs over the same data window;
    // the render continues after its resumeSamples samples (sample index sampleBegin +
    // resumeSamples) and counts resumeSeconds towards the time limit. Checked: Error otherwise.
    const Film* resumeFrom = nullptr;
    long long resumeSamples = 0;
    double resumeSeconds = 0;
    size_t localSize = 0;               // OpenCL work-group size; 0: chosen from the device (LaunchSize.h)
    bool runtimeWorkGroupSize = false;  // benchmarks: a null local size, the runtime's choice
    int samplesPerPass = 0;             // samples per pixel per pass; 0: adaptive, launches of ~0.25 s
    // Bounded launches (LaunchSize.h): work items per launch and steps per sample a launch
    // allows; 0: adapted to ~0.25 s launches. Tests force tiny ones; the image never depends on them.
    size_t rangeItems = 0;
    int stepsPerSample = 0;
    bool globalMajorant = false;        // one majorant per volume instead of per brick (benchmarks)
    // Density lookups through PNanoVDB instead of the brick pool (NB_GRID_PNANOVDB,
    // kernels/shared/nanogrid.h): the measured alternative of issue 17, item 10. Also set by the
    // environment variable NIMBUS_PATHTRACE_DENSITY=pnanovdb (docs/pathtracer.md).
    bool pnanovdbDensity = false;
    PathtraceStats* stats = nullptr;
};

// Renders ctx's scene into `film`. The film's AOVs are filled by name (beauty, L0, L1, L2plus,
// alpha, depth, variance, light_<name>); a film with no AOVs gets all of them, sized from the
// camera and its crop. Stops after scene.render.spp samples per pixel (spp 0: after the launch
// that brings the beauty's relMSE, estimated from its variance, to scene.render.noise_target) or
// after the launch that crosses scene.render.time_limit seconds, whichever comes first. Paths have
// at most scene.render.max_depth scattering events (0: unbounded). Throws Error (no OpenCL
// device, kernel build failure), Cancelled (control.progress returned false or control.cancel).
void renderPathtrace(const RenderContext& ctx, Film& film, const RenderControl& control,
                     const PathtraceOptions& pt = {});

// What the path tracer produces: L0, L1, L2plus and a per-pixel variance (engine registry).
IntegratorTraits pathtraceTraits();

// renderPathtrace behind the engine's interface.
class PathtraceIntegrator final : public Integrator {
public:
    PathtraceIntegrator(const RenderContext& ctx, PathtraceOptions options) : mCtx(&ctx), mOptions(std::move(options))
    {
    }
    Drive drive() const override { return Drive::WholeImage; }
    void renderImage(Film& film, const RenderControl& control) override
    {
        renderPathtrace(*mCtx, film, control, mOptions);
    }

private:
    const RenderContext* mCtx;
    PathtraceOptions mOptions;
};

// One line per OpenCL device, "index: name [type, ...] on platform (...)", for `nimbus devices`.
// Throws Error when there is no OpenCL platform.
std::vector<std::string> listOpenClDevices();

}  // namespace nimbus
