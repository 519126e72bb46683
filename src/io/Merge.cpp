#include "Merge.h"

#include "../core/Error.h"
#include "../pathtracer/PathtraceState.h"
#include "ExrReader.h"
#include "ExrWriter.h"
#include "Resume.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <set>
#include <variant>

#include <sys/stat.h>

namespace nimbus {

namespace {

using nlohmann::json;

struct Part {
    std::string path;
    Film film;
    std::string method;
    int frame = 0;
    std::string scene;  // nimbus:scene, compared without output (and the path tracer's stopping rules and seed)
    long long seed = 0, start = 0, n = 0;
    int tileIndex = 1, tileCount = 1;
    bool hasState = false;
    std::vector<std::string> lightAovs;  // the state's light slots ("light_<name>")
};

std::string quoted(const std::string& path)
{
    return "'" + path + "'";
}

InputError partError(const Part& p, const std::string& why)
{
    return InputError("merge: " + quoted(p.path) + ": " + why);
}

const std::string* metaText(const Film& film, const std::string& key)
{
    const FilmValue* v = film.meta(key);
    return v ? std::get_if<std::string>(v) : nullptr;
}

const int* metaInt(const Film& film, const std::string& key)
{
    const FilmValue* v = film.meta(key);
    return v ? std::get_if<int>(v) : nullptr;
}

std::string range(const Part& p)
{
    return "samples " + std::to_string(p.start) + "-" + std::to_string(p.start + p.n - 1) + " of seed " +
           std::to_string(p.seed);
}

Part readPart(const std::string& path)
{
    Part p;
    p.path = path;
    p.film = readExr(path);
    auto missing = [&](const char* key) {
        return partError(p, std::string("no nimbus:") + key + " in its header: not a frame nimbus rendered");
    };
    const std::string* scene = metaText(p.film, "scene");
    const std::string* method = metaText(p.film, "method");
    const int* frame = metaInt(p.film, "frame");
    const int* complete = metaInt(p.film, "complete");
    const int* spp = metaInt(p.film, "spp");
    if (!scene)
        throw missing("scene");
    if (!method)
        throw missing("method");
    if (!frame)
        throw missing("frame");
    if (!complete)
        throw missing("complete");
    if (!spp)
        throw missing("spp");
    if (*complete != 1)
        throw partError(p, "a checkpoint (nimbus:complete 0), not a finished part: resume it (--resume) first");
    p.method = *method;
    p.frame = *frame;
    p.n = *spp;
    p.scene = *scene;
    const json j = json::parse(*scene, nullptr, false);
    if (!j.is_object())
        throw partError(p, "nimbus:scene is not a JSON object");
    if (j.contains("render") && j["render"].is_object() && j["render"].contains("seed") &&
        j["render"]["seed"].is_number_integer())
        p.seed = j["render"]["seed"].get<long long>();
    if (const int* start = metaInt(p.film, "sample_start"))
        p.start = *start;
    if (const std::string* tile = metaText(p.film, "tile")) {
        char* end = nullptr;
        const long i = std::strtol(tile->c_str(), &end, 10);
        const long n = *end == '/' ? std::strtol(end + 1, &end, 10) : 0;
        if (*end != '\0' || i < 1 || n < 1 || i > n)
            throw partError(p, "nimbus:tile '" + *tile + "' is not I/N");
        p.tileIndex = int(i), p.tileCount = int(n);
    }
    for (const Aov& aov : p.film.aovs) {
        if (!isStateAov(aov.name))
            continue;
        p.hasState = true;
        const std::string slot = aov.name.substr(std::string(kStateAovPrefix).size());
        if (slot.rfind("light_", 0) == 0)
            p.lightAovs.push_back(slot);
    }
    std::sort(p.lightAovs.begin(), p.lightAovs.end());
    return p;
}

std::vector<std::pair<std::string, int>> outputAovs(const Film& film)
{
    std::vector<std::pair<std::string, int>> out;
    for (const Aov& aov : film.aovs)
        if (!isStateAov(aov.name))
            out.push_back({aov.name, aov.channels});
    return out;
}

void checkSameFrame(const Part& first, const Part& p)
{
    if (p.method != first.method)
        throw partError(p, "method " + p.method + ", but " + quoted(first.path) + " is " + first.method +
                               ": the parts are not of one render");
    if (p.frame != first.frame)
        throw partError(p, "frame " + std::to_string(p.frame) + ", but " + quoted(first.path) + " is frame " +
                               std::to_string(first.frame) + ": the parts are not of one frame");
    // Splits of the path tracer may differ in their stopping rules and seed; nothing else may.
    const std::string where = p.method == "pathtrace" || p.method == "vrl"
                                  ? sceneDifference(first.scene, p.scene, {"spp", "seed", "time_limit", "noise_target"})
                                  : sceneDifference(first.scene, p.scene, {});
    if (!where.empty())
        throw partError(p, "another scene than " + quoted(first.path) + " (nimbus:scene differs at " + where +
                               "): the parts are not of one frame");
    if (p.film.width != first.film.width || p.film.height != first.film.height)
        throw partError(p, "a " + std::to_string(p.film.width) + "x" + std::to_string(p.film.height) + " image, " +
                               quoted(first.path) + " " + std::to_string(first.film.width) + "x" +
                               std::to_string(first.film.height));
    if (outputAovs(p.film) != outputAovs(first.film))
        throw partError(p, "other AOVs than " + quoted(first.path));
    if (p.tileCount != first.tileCount)
        throw partError(p, "tile " + std::to_string(p.tileIndex) + "/" + std::to_string(p.tileCount) + ", but " +
                               quoted(first.path) + " is tile " + std::to_string(first.tileIndex) + "/" +
                               std::to_string(first.tileCount) + ": the tilings differ");
}

bool overlap(const Part& a, const Part& b)
{
    return a.seed == b.seed && a.start < b.start + b.n && b.start < a.start + a.n;
}

void copyWindow(const Film& from, Film& to)
{
    for (const Aov& src : from.aovs) {
        Aov* dst = to.find(src.name);
        if (!dst)
            continue;
        for (int y = from.y0; y < from.y1; ++y) {
            const size_t begin = (size_t(y) * size_t(from.width) + size_t(from.x0)) * size_t(src.channels);
            const size_t end = (size_t(y) * size_t(from.width) + size_t(from.x1)) * size_t(src.channels);
            std::copy(src.pixels.begin() + ptrdiff_t(begin), src.pixels.begin() + ptrdiff_t(end),
                      dst->pixels.begin() + ptrdiff_t(begin));
        }
    }
}

void eraseMeta(Film& film, const std::string& key)
{
    film.metadata.erase(std::remove_if(film.metadata.begin(), film.metadata.end(),
                                       [&](const auto& kv) { return kv.first == key; }),
                        film.metadata.end());
}

}  // namespace

MergeSummary mergeParts(const std::string& output, const std::vector<std::string>& paths)
{
    if (paths.empty())
        throw InputError("merge: no parts given");
    // The merged frame may not replace a part it is read from (compared by device and inode, after
    // symlinks, so hard links and other spellings of the path count).
    struct stat target;
    if (::stat(output.c_str(), &target) == 0)
        for (const std::string& path : paths) {
            struct stat part;
            if (::stat(path.c_str(), &part) == 0 && part.st_dev == target.st_dev && part.st_ino == target.st_ino)
                throw InputError("merge: the output " + quoted(output) + " is the part " + quoted(path) +
                                 "; writing it would destroy it");
        }
    std::vector<Part> parts;
    for (const std::string& path : paths) {
        for (const Part& p : parts)
            if (p.path == path)
                throw InputError("merge: " + quoted(path) + " is given twice");
        parts.push_back(readPart(path));
    }
    const Part& first = parts.front();
    for (const Part& p : parts)
        checkSameFrame(first, p);

    // Tiles: every one of 1..N present, each over one data window.
    const int tileCount = first.tileCount;
    std::map<int, std::vector<const Part*>> tiles;
    for (const Part& p : parts)
        tiles[p.tileIndex].push_back(&p);
    for (int i = 1; i <= tileCount; ++i)
        if (!tiles.count(i))
            throw InputError("merge: tile " + std::to_string(i) + "/" + std::to_string(tileCount) +
                             " is missing: the parts do not cover the frame");

    // Within a tile, samples no two parts share; every tile the same samples.
    const bool pooled = first.method == "pathtrace" || first.method == "vrl";
    std::vector<std::tuple<long long, long long, long long>> samplesOfFirstTile;
    for (const auto& [index, group] : tiles) {
        const Part& a = *group.front();
        for (size_t i = 0; i < group.size(); ++i) {
            const Part& p = *group[i];
            if (p.film.x0 != a.film.x0 || p.film.x1 != a.film.x1 || p.film.y0 != a.film.y0 || p.film.y1 != a.film.y1)
                throw partError(p, "tile " + std::to_string(index) + " over other pixels than " + quoted(a.path));
            for (size_t j = 0; j < i; ++j) {
                const Part& q = *group[j];
                if (!pooled)
                    throw partError(p, "also tile " + std::to_string(index) + "/" + std::to_string(tileCount) +
                                           " like " + quoted(q.path) + "; method " + p.method +
                                           " has no sample splits: the parts overlap");
                if (overlap(p, q))
                    throw partError(p, range(p) + " overlap " + quoted(q.path) + "'s " + range(q) +
                                           ": the parts overlap");
            }
            if (pooled && group.size() > 1 && !p.hasState)
                throw partError(p, "has no running estimate (state AOVs) to pool: render sample splits with "
                                   "--samples A-B");
            if (pooled && group.size() > 1 && p.lightAovs != a.lightAovs)
                throw partError(p, "its running estimate has other lights than " + quoted(a.path) + "'s");
        }
        std::vector<std::tuple<long long, long long, long long>> samples;
        for (const Part* p : group)
            samples.emplace_back(p->seed, p->start, p->n);
        std::sort(samples.begin(), samples.end());
        if (index == tiles.begin()->first)
            samplesOfFirstTile = samples;
        else if (samples != samplesOfFirstTile)
            throw partError(*group.front(), "tile " + std::to_string(index) + " has other samples than tile " +
                                                std::to_string(tiles.begin()->first) + ": the splits differ per tile");
    }

    // The merged frame: the parts' output AOVs over the union of their windows.
    Film merged;
    merged.width = first.film.width, merged.height = first.film.height;
    merged.x0 = first.film.x0, merged.x1 = first.film.x1;
    merged.y0 = first.film.y0, merged.y1 = first.film.y1;
    for (const Part& p : parts) {
        merged.x0 = std::min(merged.x0, p.film.x0), merged.x1 = std::max(merged.x1, p.film.x1);
        merged.y0 = std::min(merged.y0, p.film.y0), merged.y1 = std::max(merged.y1, p.film.y1);
    }
    for (const Aov& aov : first.film.aovs)
        if (!isStateAov(aov.name))
            merged.add(aov.name, aov.channels, aov.isData);

    long long spp = 0;
    double renderSeconds = 0;
    for (const Part& p : parts)
        if (const std::string* t = metaText(p.film, "render_time"))
            renderSeconds += std::atof(t->c_str());
    for (const auto& [index, group] : tiles) {
        if (group.size() == 1) {
            copyWindow(group.front()->film, merged);
            spp = group.front()->n;
            continue;
        }
        const std::vector<std::string>& lights = group.front()->lightAovs;
        std::vector<std::vector<float>> states(group.size());
        std::vector<StatePart> pool;
        for (size_t i = 0; i < group.size(); ++i) {
            if (!readState(group[i]->film, lights, states[i]))
                throw partError(*group[i], "its running estimate (state AOVs) is incomplete");
            pool.push_back({&states[i], group[i]->n});
        }
        const std::vector<float> acc = poolStates(pool, lights.size(), spp);
        Film window = std::move(merged);  // resolve over this tile's window only
        const int x0 = window.x0, x1 = window.x1, y0 = window.y0, y1 = window.y1;
        window.x0 = group.front()->film.x0, window.x1 = group.front()->film.x1;
        window.y0 = group.front()->film.y0, window.y1 = group.front()->film.y1;
        resolveState(acc, spp, lights, window);
        window.x0 = x0, window.x1 = x1, window.y0 = y0, window.y1 = y1;
        merged = std::move(window);
    }

    // The header: the first part's, now of the whole frame with all its samples.
    merged.metadata = first.film.metadata;
    eraseMeta(merged, "tile");
    eraseMeta(merged, "sample_start");
    merged.set("complete", 1);
    merged.set("spp", int(spp));
    merged.set("samples", double(spp) * double(merged.x1 - merged.x0) * double(merged.y1 - merged.y0));
    merged.set("render_time", std::to_string(renderSeconds));
    merged.set("merged_parts", int(parts.size()));
    if (pooled) {
        merged.set("pathtrace_spp", std::to_string(spp));
        std::set<long long> seeds;
        for (const Part& p : parts)
            seeds.insert(p.seed);
        std::string list;
        for (long long s : seeds)
            list += (list.empty() ? "" : ",") + std::to_string(s);
        merged.set("seed", list);
    }
    writeExr(merged, output);

    MergeSummary summary;
    summary.parts = int(parts.size());
    summary.tiles = tileCount;
    summary.splitsPerTile = int(tiles.begin()->second.size());
    summary.spp = spp;
    return summary;
}

}  // namespace nimbus
