#include "FarmPlan.h"

#include "../core/Error.h"
#include "../engine/Renderer.h"
#include "../io/Outputs.h"
#include "../scene/FrameTokens.h"
#include "../scene/SceneValidate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace nimbus {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

std::string padded(int frame)
{
    char text[32];
    const long long f = frame;
    std::snprintf(text, sizeof text, f < 0 ? "m%04lld" : "%04lld", f < 0 ? -f : f);
    return text;
}

// Where part (tile i of n, samples [a, b]) of the frame whose output is `file` goes:
// "<dir>/parts/<stem>.t<i>of<n>[.s<a>-<b>]<ext>", out of the way of output globs.
std::string partPath(const std::string& file, int i, int n, bool split, long long a, long long b)
{
    const fs::path path(file);
    std::string name = path.stem().string() + ".t" + std::to_string(i) + "of" + std::to_string(n);
    if (split)
        name += ".s" + std::to_string(a) + "-" + std::to_string(b);
    name += path.extension().string().empty() ? ".exr" : path.extension().string();
    return (path.parent_path() / "parts" / name).string();
}

}  // namespace

json planFarm(const Scene& templ, const FarmPlanOptions& o)
{
    const std::string where = templ.sourcePath.empty() ? std::string() : templ.sourcePath + ": ";
    if (o.frames.empty())
        throw InputError("--frames: no frames");
    if (o.tiles < 1)
        throw InputError("--tiles: want a count of 1 or more, got " + std::to_string(o.tiles));
    if (o.sampleSplits < 1)
        throw InputError("--sample-splits: want a count of 1 or more, got " + std::to_string(o.sampleSplits));
    const bool pathtrace = isProgressive(templ.render.method);
    const long long spp = templ.render.spp;
    if (o.sampleSplits > 1) {
        if (!pathtrace)
            throw InputError("--sample-splits: only the path tracer splits a frame's samples (method " +
                             std::string(methodName(templ.render.method)) + "); split it with --tiles");
        if (spp <= 0)
            throw InputError(where + "render.spp: --sample-splits divides render.spp, and it is 0 (the noise "
                                     "target decides the samples); set render.spp");
        if (o.sampleSplits > spp)
            throw InputError("--sample-splits: " + std::to_string(o.sampleSplits) + " splits of render.spp " +
                             std::to_string(spp) + " would leave some empty");
    }
    const bool split = o.tiles > 1 || o.sampleSplits > 1;
    // Deep output is written by a whole frame only (nimbus render refuses it with --tile; the
    // path tracer, the only method with sample splits, writes none).
    if (o.tiles > 1 && !templ.output.deep.empty())
        throw InputError(where + "output.deep: --tiles " + std::to_string(o.tiles) +
                         " splits each frame, and a tile writes no deep file (nimbus merge joins flat files only)");
    if (o.frames.size() > 1 && !templ.output.deep.empty() && !hasFrameTokens(templ.output.deep))
        throw InputError(where + "output.deep: '" + templ.output.deep +
                         "' has no frame token ($F, $F4, ####): the frames would overwrite each other");
    if (o.frames.size() > 1 && !hasFrameTokens(templ.output.file))
        throw InputError(where + "output.file: '" + templ.output.file +
                         "' has no frame token ($F, $F4, ####): the frames would overwrite each other");

    json tasks = json::array(), renderIds = json::array(), mergeIds = json::array();
    for (int frame : o.frames) {
        Scene scene = sceneAtFrame(templ, frame);
        validateScene(scene);
        checkOutputs(scene, pathtrace);
        if (o.tiles > 1) {  // every tile has rows
            const Camera& c = scene.camera;
            Film window;
            window.height = c.height;
            window.y0 = std::max(0, int(std::floor(c.crop[2] * c.height)));
            window.y1 = std::min(c.height, int(std::ceil(c.crop[3] * c.height)));
            try {
                applyTile(window, o.tiles, o.tiles);
            } catch (const InputError& e) {
                std::string text = e.what();
                throw InputError("--tiles " + std::to_string(o.tiles) + text.substr(text.find(':')));
            }
        }
        // Absolute, as every path of a task: tasks may run in any directory. Output paths resolve
        // against the current directory (docs/scene-format.md), the one nimbus farm plan runs in.
        const std::string output = fs::absolute(scene.output.file).lexically_normal().string();
        const std::string preview =
            scene.output.preview.empty() ? std::string() : fs::absolute(scene.output.preview).lexically_normal().string();
        const std::string deep =
            scene.output.deep.empty() ? std::string() : fs::absolute(scene.output.deep).lexically_normal().string();
        std::vector<std::string> base = {o.nimbus, "render"};
        base.insert(base.end(), o.sceneArgs.begin(), o.sceneArgs.end());
        // No -q: off a terminal the render's progress lines are what a farm's log shows of it.
        base.insert(base.end(), {"--frame", std::to_string(frame)});
        auto renderTask = [&](const std::string& id, const std::string& out, int tile, long long a, long long b,
                              bool samples) {
            json t;
            t["id"] = id;
            t["kind"] = "render";
            t["frame"] = frame;
            t["tile"] = tile > 0 ? json(std::to_string(tile) + "/" + std::to_string(o.tiles)) : json(nullptr);
            t["samples"] = samples ? json(std::to_string(a) + "-" + std::to_string(b)) : json(nullptr);
            std::vector<std::string> command = base;
            command.insert(command.end(), {"-o", out});
            command.insert(command.end(), {"--preview", split ? std::string() : preview});  // a part has none
            if (!deep.empty())
                command.insert(command.end(), {"--set", "output.deep=" + json(deep).dump()});
            if (tile > 0)
                command.insert(command.end(), {"--tile", std::to_string(tile) + "/" + std::to_string(o.tiles)});
            if (samples)
                command.insert(command.end(), {"--samples", std::to_string(a) + "-" + std::to_string(b)});
            if (pathtrace) {
                char seconds[32];
                std::snprintf(seconds, sizeof seconds, "%g", o.checkpointSeconds);
                command.insert(command.end(), {"--checkpoint", seconds, "--resume"});
            }
            t["command"] = command;
            json outputs = json::array({out});
            if (!split && !preview.empty())
                outputs.push_back(preview);
            if (!deep.empty())
                outputs.push_back(deep);
            t["outputs"] = outputs;
            t["checkpoint"] = pathtrace ? json(checkpointPath(out)) : json(nullptr);
            t["resumable"] = pathtrace;
            t["retries"] = o.retries;
            t["depends_on"] = json::array();
            renderIds.push_back(id);
            tasks.push_back(t);
        };
        const std::string frameId = "f" + padded(frame);
        if (!split) {
            renderTask("render." + frameId, output, 0, 0, 0, false);
            continue;
        }
        std::vector<std::string> parts;
        json waits = json::array();
        for (int i = 1; i <= o.tiles; ++i)
            for (int k = 0; k < o.sampleSplits; ++k) {
                const bool samples = o.sampleSplits > 1;
                const long long a = samples ? k * spp / o.sampleSplits : 0;
                const long long b = samples ? (k + 1) * spp / o.sampleSplits - 1 : 0;
                const int tile = o.tiles > 1 ? i : 0;
                const std::string out = partPath(output, i, o.tiles, samples, a, b);
                std::string id = "render." + frameId + ".t" + std::to_string(i);
                if (samples)
                    id += ".s" + std::to_string(k + 1);
                renderTask(id, out, tile, a, b, samples);
                parts.push_back(out);
                waits.push_back(id);
            }
        json m;
        m["id"] = "merge." + frameId;
        m["kind"] = "merge";
        m["frame"] = frame;
        m["tile"] = nullptr;
        m["samples"] = nullptr;
        std::vector<std::string> command = {o.nimbus, "merge", "-q", output};
        command.insert(command.end(), parts.begin(), parts.end());
        m["command"] = command;
        m["outputs"] = json::array({output});
        m["inputs"] = parts;
        m["checkpoint"] = nullptr;
        m["resumable"] = false;
        m["retries"] = o.retries;
        m["depends_on"] = waits;
        mergeIds.push_back(m["id"]);
        tasks.push_back(m);
    }

    json plan;
    plan["nimbus_farm_plan"] = 1;
    plan["cwd"] = o.cwd;
    plan["scene"] = templ.sourcePath.empty() ? json(nullptr) : json(fs::absolute(templ.sourcePath).string());
    plan["method"] = methodName(templ.render.method);
    plan["frames"] = o.frames;
    plan["tiles"] = o.tiles;
    plan["sample_splits"] = o.sampleSplits;
    plan["tasks"] = tasks;
    // Homogeneous groups, for schedulers that run arrays of like tasks (a Slurm job array each,
    // the merges' array starting after the renders' has succeeded).
    json groups = json::array();
    groups.push_back({{"name", "render"}, {"tasks", renderIds}, {"depends_on", json::array()}});
    if (!mergeIds.empty())
        groups.push_back({{"name", "merge"}, {"tasks", mergeIds}, {"depends_on", json::array({"render"})}});
    plan["groups"] = groups;
    return plan;
}

}  // namespace nimbus
