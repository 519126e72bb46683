// fuzz_depth: a depth image's bytes through the holdout-depth loader (HoldoutDepth::load,
// src/geometry/HoldoutDepth.h), as a scene's camera.holdout_depth is read (issue 18, item 5).
//
// Input: an OpenEXR file's bytes (read through OpenImageIO, channel "Z"), for a 16x16 camera: a
// square image of another size is resampled, any other aspect ratio refused. Besides "only
// InputError" (FuzzSupport.h), a depth map that loads is looked up at the camera's corners,
// centre and a pixel inside: a depth is never NaN or negative (0 and inf mean no holdout, and
// the loader refuses NaN and negative texels).
//
// OpenImageIO and OpenEXR are Debian's GCC builds, not instrumented: coverage is nimbus's side
// only; crashes and memory growth inside them are seen. Corpus: tests/fuzz/corpus/depth
// (tests/fuzz/make_seeds.py).
#include "FuzzSupport.h"

#include "geometry/HoldoutDepth.h"

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <string>

using namespace nimbus;

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    fuzz::quietLogs();
    // One thread: libFuzzer runs one input at a time, and a pool only adds noise to exec/s.
    OIIO::attribute("threads", 1);
    OIIO::attribute("exr_threads", -1);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    Scene scene;
    scene.sourcePath = "fuzz.json";
    scene.camera.width = scene.camera.height = 16;
    // The loader checks a map's pixels against render.memory_limit before allocating them: 64 MiB,
    // well under libFuzzer's -rss_limit_mb, so an image that loads fits and one that does not is
    // the loader's InputError (as in fuzz_vdb).
    scene.render.memoryLimit = 67108864.0f;
    scene.camera.holdoutDepth.file = fuzz::writeInput(data, size, ".exr");
    fuzz::expectOnlyInputErrors([&] {
        const std::unique_ptr<HoldoutDepth> depth = HoldoutDepth::load(scene);
        if (!depth)
            fuzz::finding("no depth map for a camera that names one");
        for (float y : {0.0f, 0.5f, 7.3f, 8.0f, 15.99f, 16.0f})
            for (float x : {0.0f, 0.5f, 7.3f, 8.0f, 15.99f, 16.0f}) {
                const float z = depth->depthAt(x, y);
                if (std::isnan(z) || z < 0.0f)
                    fuzz::finding("depth " + std::to_string(z) + " at (" + std::to_string(x) + ", " +
                                  std::to_string(y) + ")");
            }
    });
    return 0;
}
