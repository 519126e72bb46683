// fuzz_vdb: a VDB file's bytes through the volume loader, as `nimbus render` and `nimbus info`
// load a scene's "vdb" source (issue 18, item 5): VdbFileReader (header, descriptors, metadata,
// transform, tree), the role grids' checks, the resampling of role grids onto the density's
// lattice, clamping and the conversion to bricks (buildVolumes, src/volume/VolumeData.h).
//
// Input: the file's bytes. Each input is loaded as a scene volume with the default roles
// (density, temperature, flame or heat); a file that loads is loaded again with velocity blur on
// (medium.velocity_scale 1, which requires a vec3 "vel" grid), the only other path that reads
// grids without an AX shader. render.memory_limit is 64 MiB (below).
//
// Only InputError may come out (FuzzSupport.h). OpenVDB itself is Debian's GCC build and not
// instrumented: libFuzzer sees coverage of nimbus's side only, and ASan sees OpenVDB's heap
// errors only where they pass through intercepted calls (memcpy, new/delete); crashes and memory
// growth it sees everywhere. Corpus: tests/fuzz/corpus/vdb (tests/fuzz/make_seeds.py).
#include "FuzzSupport.h"

#include "scene/SceneJson.h"
#include "volume/VolumeData.h"

#include <nlohmann/json.hpp>

#include <string>

using namespace nimbus;

namespace {

Scene sceneWith(const std::string& vdbPath, bool velocityBlur)
{
    nlohmann::json volume = {{"source", {{"type", "vdb"}, {"file", vdbPath}}}};
    if (velocityBlur)
        volume["medium"] = {{"velocity_scale", 1}};
    // The load checks what it would allocate against render.memory_limit (a role grid's
    // resampling), and a resample's walk is bounded by what it allocates (ActiveResample.h): 64 MiB
    // here, so that a file asking for more is an input error, as it would be on a machine of that
    // memory. With 1 GiB (until 2026-12-06) mutants whose role grid legitimately resampled into
    // 10^6-10^7 voxels of a thin density lattice took 10-170 s each in the instrumented harness
    // (0.7-7 s released), the corpus drifted into them and the rate fell from ~350 to ~13 exec/s
    // (docs/robustness.md, session 26): the fuzzer explores the loader's reading and checks on
    // small files; large legitimate resamples are the tests' and the benchmarks' (test_vdbload.cpp).
    nlohmann::json doc = {{"volumes", nlohmann::json::array({volume})}, {"render", {{"memory_limit", 67108864.0}}}};
    if (velocityBlur)
        doc["camera"] = {{"shutter", {-0.25, 0.25}}};
    return sceneFromJson(doc, "");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    fuzz::quietLogs();
    return 0;
}

// The file's extension picks the reader (VdbLoad.cpp): fuzz_nvdb.cpp includes this file with ".nvdb".
#ifndef NIMBUS_FUZZ_VDB_EXTENSION
#define NIMBUS_FUZZ_VDB_EXTENSION ".vdb"
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    // The default shader (shaders/default.ax, the same text for every input) is compiled once per
    // process, as a shot's frames share it (VolumeCache): its LLVM compile took 1-3 s of each
    // input with a temperature or flame grid under ASan, and a third of nvdb's corpus had one
    // (docs/robustness.md, session 30). The volumes are never reused: every input is loaded.
    static VolumeCache cache;
    cache.volumes.clear();
    const std::string path = fuzz::writeInput(data, size, NIMBUS_FUZZ_VDB_EXTENSION);
    bool loaded = false;
    fuzz::expectOnlyInputErrors([&] {
        buildVolumes(sceneWith(path, false), &cache);
        loaded = true;
    });
    cache.volumes.clear();
    if (loaded)
        fuzz::expectOnlyInputErrors([&] { buildVolumes(sceneWith(path, true), &cache); });
    return 0;
}
