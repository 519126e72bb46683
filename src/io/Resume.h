// Resume.h: `nimbus render --resume` (docs/farm.md, issue 16 item 5): a path-tracer render
// killed at any moment (kill -9 included) continues from its last checkpoint.
//
// Why it is exact: a checkpoint (written atomically, AtomicFile.h, so it is the old one or the
// new one, never half of one) holds the running estimate itself, the accumulator's float state
// AOVs (PathtraceState.h), and the number of samples in it. Each pixel's samples are drawn from
// (seed, pixel, sample index) and added to the running means one by one in sample order, so the
// render continued from sample k on is the uninterrupted render bit for bit, however the launches
// fall and wherever it was killed.
#pragma once

#include "../render/Film.h"
#include "../scene/Scene.h"

#include <optional>
#include <string>

namespace nimbus {

struct ResumePoint {
    Film film;              // the checkpoint: its state AOVs over the render's data window
    long long samples = 0;  // samples per pixel in its running estimate
    double seconds = 0;     // render time it had spent
};

// What a render must match to take a checkpoint over.
struct ResumeKey {
    int tileIndex = 0, tileCount = 0;  // --tile I/N (0/0: none)
    bool split = false;                // --samples A-B
    long long sampleBegin = 0;         // A
};

// The checkpoint at `path` when one exists (std::nullopt: none, render from the start). Throws
// InputError naming the checkpoint when it is not a checkpoint of this render: not a checkpoint
// (nimbus:complete 1), another method, frame, scene (compared without output and the stopping
// rules spp, time_limit and noise_target, which a resumed render may change), tile or sample
// split, or one without a running estimate.
std::optional<ResumePoint> loadCheckpoint(const Scene& scene, const std::string& path, const ResumeKey& key);

// Where two nimbus:scene headers differ, as a JSON pointer ("/render/step"), or "" when they do
// not; `output` is left out, and so are `ignored` keys of `render`.
std::string sceneDifference(const std::string& a, const std::string& b, std::initializer_list<const char*> ignored);

}  // namespace nimbus
