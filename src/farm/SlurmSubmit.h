// SlurmSubmit.h: `nimbus farm submit --engine slurm` (issue 16, item 6; docs/farm.md, "Slurm"): the
// Slurm adapter of the job description (FarmPlan.h). The plan's groups become job arrays, one
// array task per plan task:
//
//   render.sbatch   sbatch --array=0-<n-1>, one render task (frame, tile, sample split) per index
//   merge.sbatch    sbatch --array=0-<m-1> --dependency=afterok:<render job> --kill-on-invalid-dep=yes
//
// Both are written into a job folder the user can read and resubmit by hand (submit.sh), beside
// plan.json and logs/ (--output/--error per array task, %A_%a). A task's script runs the plan's
// command up to 1 + retries times: exit 2 (bad input) is not retried; a task killed (a signal,
// kill -9 of nimbus) or failed (exit 1) is. `--requeue` lets Slurm requeue a preempted task, and
// path-tracer commands carry `--checkpoint S --resume`, so a rerun continues from the checkpoint.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace nimbus {

struct SlurmOptions {
    std::string jobDir;                   // the folder for scripts and logs; created, must be empty or absent
    bool dryRun = false;                  // write the scripts, submit nothing
    std::vector<std::string> sbatchArgs;  // extra sbatch options for both arrays (--partition=..., --cpus-per-task=...)
    std::string jobName = "nimbus";       // the arrays' names: <jobName>-render, <jobName>-merge
};

struct SlurmSubmission {
    std::string jobDir;
    std::string renderScript, mergeScript;  // mergeScript empty when no frame is split
    std::string renderJobId, mergeJobId;    // empty on a dry run (and mergeJobId without merges)
    size_t renderTasks = 0, mergeTasks = 0;
};

// Writes the job folder for `plan` (planFarm's JSON) and, unless a dry run, submits it with sbatch
// found on PATH. InputError (one line) when the folder cannot be written, sbatch is not on PATH or
// refuses a submission; a render array already submitted when the merge array is refused is
// cancelled (scancel) so no half of a job is left queued.
SlurmSubmission submitSlurm(const nlohmann::json& plan, const SlurmOptions& options);

}  // namespace nimbus
