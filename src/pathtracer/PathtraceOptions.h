// PathtraceOptions.h: the path tracer's host options and statistics, apart from
// Pathtracer.h so that Renderer.h (RenderOptions) can carry them without a circular include.
#pragma once

#include "../render/Film.h"

#include <cstddef>
#include <functional>
#include <string>

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
    size_t workGroups = 0;      // work-groups per launch (0: the runtime chose)
    double noiseRelMse = 0;     // with a noise target: the beauty's relMSE from its variance at the end
                                // (infinite below 64 spp, where it is not measured)
    std::string device;
    std::string defines;
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
    size_t localSize = 0;        // OpenCL work-group size; 0: chosen from the device (LaunchSize.h)
    bool runtimeWorkGroupSize = false;  // benchmarks: a null local size, the runtime's choice
    int samplesPerPass = 0;      // samples per pixel per launch; 0: adaptive, ~0.5 s launches
    bool globalMajorant = false; // one majorant per volume instead of per brick (benchmarks)
    PathtraceStats* stats = nullptr;
};

}  // namespace nimbus
