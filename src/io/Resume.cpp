#include "Resume.h"

#include "../core/Error.h"
#include "../pathtracer/PathtraceState.h"
#include "../scene/SceneJson.h"
#include "ExrReader.h"

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <variant>

namespace nimbus {

namespace {

using nlohmann::json;

json comparable(const std::string& text, std::initializer_list<const char*> ignored)
{
    json j = json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object())
        return json();
    j.erase("output");
    if (j.contains("render") && j["render"].is_object())
        for (const char* key : ignored)
            j["render"].erase(key);
    return j;
}

}  // namespace

std::string sceneDifference(const std::string& a, const std::string& b, std::initializer_list<const char*> ignored)
{
    const json ja = comparable(a, ignored), jb = comparable(b, ignored);
    if (ja.is_null() || jb.is_null())
        return ja.is_null() && jb.is_null() ? std::string("(neither is JSON)") : std::string("(not JSON)");
    if (ja == jb)
        return "";
    const json patch = json::diff(ja, jb);
    return patch.empty() ? std::string("?") : patch[0].value("path", std::string("?"));
}

std::optional<ResumePoint> loadCheckpoint(const Scene& scene, const std::string& path, const ResumeKey& key)
{
    std::error_code ec;
    if (!std::filesystem::exists(path, ec))
        return std::nullopt;
    auto fail = [&](const std::string& why) {
        return InputError("--resume: checkpoint '" + path + "': " + why +
                          " (remove it to render from the start)");
    };
    ResumePoint r;
    try {
        r.film = readExr(path);
    } catch (const InputError& e) {
        throw InputError("--resume: checkpoint " + std::string(e.what()));
    }
    auto text = [&](const char* k) -> const std::string* {
        const FilmValue* v = r.film.meta(k);
        return v ? std::get_if<std::string>(v) : nullptr;
    };
    auto integer = [&](const char* k) -> const int* {
        const FilmValue* v = r.film.meta(k);
        return v ? std::get_if<int>(v) : nullptr;
    };
    const int* complete = integer("complete");
    const int* frame = integer("frame");
    const std::string* method = text("method");
    const std::string* sceneJson = text("scene");
    const std::string* spp = text("pathtrace_spp");
    if (!complete || !frame || !method || !sceneJson || !spp)
        throw fail("not a nimbus checkpoint (its header lacks nimbus:complete, frame, method, scene or pathtrace_spp)");
    if (*complete != 0)
        throw fail("a finished frame (nimbus:complete 1), not a checkpoint");
    if (*method != methodName(scene.render.method))
        throw fail("method " + *method + ", the render's is " + methodName(scene.render.method));
    if (*frame != scene.render.frame)
        throw fail("frame " + std::to_string(*frame) + ", the render's is frame " + std::to_string(scene.render.frame));
    const std::string where = sceneDifference(*sceneJson, sceneToJson(scene).dump(), {"spp", "time_limit", "noise_target"});
    if (!where.empty())
        throw fail("of another scene (nimbus:scene differs at " + where + ")");
    const std::string* tile = text("tile");
    const std::string wantTile =
        key.tileCount > 0 ? std::to_string(key.tileIndex) + "/" + std::to_string(key.tileCount) : std::string();
    if ((tile ? *tile : std::string()) != wantTile)
        throw fail("tile '" + (tile ? *tile : std::string("none")) + "', the render's is '" +
                   (wantTile.empty() ? std::string("none") : wantTile) + "'");
    const int* start = integer("sample_start");
    if (key.split != (start != nullptr) || (start && *start != key.sampleBegin))
        throw fail("samples from " + (start ? std::to_string(*start) : std::string("0 (no split)")) +
                   ", the render's from " + (key.split ? std::to_string(key.sampleBegin) : std::string("0 (no split)")));
    char* end = nullptr;
    r.samples = std::strtoll(spp->c_str(), &end, 10);
    if (end == spp->c_str() || *end != '\0' || r.samples < 0)
        throw fail("nimbus:pathtrace_spp '" + *spp + "' is not a sample count");
    bool hasState = false;
    for (const Aov& aov : r.film.aovs)
        hasState = hasState || isStateAov(aov.name);
    if (!hasState)
        throw fail("it has no running estimate (state AOVs): written by a nimbus without --resume");
    if (const std::string* seconds = text("render_time"))
        r.seconds = std::atof(seconds->c_str());
    return r;
}

}  // namespace nimbus
