// FarmPlan.h: `nimbus farm plan` (issue 16, item 6; docs/farm.md): a shot as the tasks of a render
// farm, described without naming one: every task's command, outputs, checkpoint, retries and the
// tasks it waits for, as JSON. An adapter for a scheduler (Slurm's job arrays, OpenCue's
// outlines, Deadline, Tractor) turns it into that scheduler's jobs; it need know nothing of
// nimbus beyond this description.
//
// Per frame: one render task when the frame is not split; else N tiles x K sample splits render
// tasks writing parts beside the frame's output (in "parts/") and one merge task depending on them
// (`nimbus merge`). Path-tracer tasks checkpoint and resume (`--checkpoint S --resume`), so a
// preempted or retried task continues where it stopped.
#pragma once

#include "../scene/Scene.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace nimbus {

struct FarmPlanOptions {
    std::vector<int> frames;             // in the order given
    int tiles = 1;                       // N of --tile I/N
    int sampleSplits = 1;                // K path-tracer sample splits of render.spp
    double checkpointSeconds = 60;       // path tracer: --checkpoint of every render task
    int retries = 2;                     // how often a scheduler should rerun a failed task
    std::string nimbus;                  // the binary the commands run
    std::vector<std::string> sceneArgs;  // how a command names the scene: the absolute file, --set ...
    std::string cwd;                     // the directory commands run in (relative outputs)
};

// The job description (docs/farm.md, "The job description"). Every frame is checked first (its
// scene values, the output path's frame token for several frames, the tile count against the
// data window's rows, the sample splits against render.spp and the method): InputError naming
// the flag or key.
nlohmann::json planFarm(const Scene& templ, const FarmPlanOptions& options);

}  // namespace nimbus
