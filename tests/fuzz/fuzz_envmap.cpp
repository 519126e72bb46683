// fuzz_envmap: an HDR map's bytes through the environment-map loader (EnvironmentMap::load,
// src/render/EnvironmentMap.h), as an environment light's "map" is read (issue 18, item 5).
//
// Input: an OpenEXR file's bytes, or a Radiance .hdr file's when it starts with "#?" (OpenImageIO
// picks the reader by the extension). Besides "only InputError" (FuzzSupport.h), a map that
// loads must give the path tracer a distribution it can sample: its integral not NaN and >= 0
// (texels up to FLT_MAX are accepted, so the float integral may be inf: the film's non-finite
// net, docs/volumes.md, is what stops such a light), and sample() a unit direction with a finite
// pdf >= 0 whose pdf() is finite too. (pdf(sample) need not equal the sampler's pdf exactly: a
// sample on a texel's edge may look up its neighbour.)
//
// OpenImageIO and OpenEXR are Debian's GCC builds, not instrumented: coverage is nimbus's side
// only; crashes and memory growth inside them are seen. Corpus: tests/fuzz/corpus/envmap
// (tests/fuzz/make_seeds.py).
#include "FuzzSupport.h"

#include "render/EnvironmentMap.h"

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstring>
#include <string>

using namespace nimbus;

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    fuzz::quietLogs();
    OIIO::attribute("threads", 1);
    OIIO::attribute("exr_threads", -1);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    const bool hdr = size >= 2 && std::memcmp(data, "#?", 2) == 0;
    Scene scene;
    scene.sourcePath = "fuzz.json";
    // The loader checks a map's pixels against render.memory_limit before allocating them: 64 MiB,
    // well under libFuzzer's -rss_limit_mb, so an image that loads fits and one that does not is
    // the loader's InputError (as in fuzz_vdb).
    scene.render.memoryLimit = 67108864.0f;
    Light light;
    light.type = LightType::Environment;
    light.map = fuzz::writeInput(data, size, hdr ? ".hdr" : ".exr");
    scene.lights.push_back(light);
    fuzz::expectOnlyInputErrors([&] {
        const std::shared_ptr<const EnvironmentMap> map = EnvironmentMap::load(scene, 0);
        if (!map)
            fuzz::finding("no map for a light that names one");
        const Rgb integral = map->integral();
        for (float c : {integral.x, integral.y, integral.z})
            if (std::isnan(c) || c < 0.0f)
                fuzz::finding("integral " + std::to_string(c));
        for (float u0 : {0.0f, 0.25f, 0.5f, 0.999f})
            for (float u1 : {0.0f, 0.3f, 0.999f}) {
                float pdf = -1.0f;
                const float3 w = map->sample(u0, u1, pdf);
                const float len = std::sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
                if (!(std::fabs(len - 1.0f) < 1e-3f) || !std::isfinite(pdf) || pdf < 0.0f)
                    fuzz::finding("sample (" + std::to_string(u0) + ", " + std::to_string(u1) + "): |w| " +
                                  std::to_string(len) + ", pdf " + std::to_string(pdf));
                const float lookup = map->pdf(w);
                if (!std::isfinite(lookup) || lookup < 0.0f)
                    fuzz::finding("pdf " + std::to_string(lookup) + " at a sampled direction");
            }
    });
    return 0;
}
