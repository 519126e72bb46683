// ReferenceCache.cpp: the cached reference (ReferenceCache.h).
#include "ReferenceCache.h"
#include "FilmAccess.h"

#include "../core/Error.h"
#include "../scene/SceneJson.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include <unistd.h>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

uint64_t fnv1a(const std::string& s)
{
    uint64_t h = 1469598103934665603ull;
    for (unsigned char c : s)
        h = (h ^ c) * 1099511628211ull;
    return h;
}

std::string defaultCacheDir()
{
    if (const char* d = std::getenv("NIMBUS_CACHE_DIR"); d && *d)
        return d;
    if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d)
        return std::string(d) + "/nimbus";
    if (const char* d = std::getenv("HOME"); d && *d)
        return std::string(d) + "/.cache/nimbus";
    return "/tmp/nimbus-cache";
}

// The reference's AOVs that the comparison reads, as a flat binary file (magic, size, AOVs).
const char* kCachedAovs[] = {"beauty", "L0", "L1", "L2plus", "variance"};

}  // namespace

std::string referenceCachePath(const Scene& refScene, const std::string& cacheDir)
{
    nlohmann::json doc = sceneToJson(refScene);
    doc.erase("output");
    // Keys that only WKB and vrl read do not change the path tracer's picture: comparing WKB's
    // models on one scene (--set render.wkb_orders3=kernel, say) reuses one reference.
    if (auto render = doc.find("render"); render != doc.end() && render->is_object())
        for (auto it = render->begin(); it != render->end();)
            it = it.key().rfind("wkb_", 0) == 0 || it.key().rfind("vrl_", 0) == 0 ? render->erase(it) : std::next(it);
    const uint64_t key = fnv1a(doc.dump());
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(key));
    const std::string dir = cacheDir.empty() ? defaultCacheDir() + "/compare" : cacheDir;
    return dir + "/ref-" + hex + ".bin";
}

void saveReference(const Film& f, const std::string& path)
{
    std::ostringstream o(std::ios::binary);
    o.write("NBCMPREF", 8);
    int32_t hdr[2] = {f.width, f.height};
    o.write(reinterpret_cast<const char*>(hdr), sizeof(hdr));
    for (const char* name : kCachedAovs) {
        const Aov& a = requireAov(f, name);
        int32_t ch = a.channels;
        o.write(reinterpret_cast<const char*>(&ch), sizeof(ch));
        o.write(reinterpret_cast<const char*>(a.pixels.data()), std::streamsize(a.pixels.size() * sizeof(float)));
    }
    fs::create_directories(fs::path(path).parent_path());
    std::string tmp = path + ".tmp" + std::to_string(::getpid());
    {
        std::ofstream out(tmp, std::ios::binary);
        out << o.str();
        if (!out)
            throw Error("compare: cannot write " + tmp);
    }
    fs::rename(tmp, path);
}

bool loadReference(const std::string& path, Film& f)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return false;
    char magic[8];
    int32_t hdr[2];
    if (!in.read(magic, 8) || std::string(magic, 8) != "NBCMPREF" ||
        !in.read(reinterpret_cast<char*>(hdr), sizeof(hdr)))
        return false;
    f = Film{};
    f.width = hdr[0], f.height = hdr[1], f.x1 = hdr[0], f.y1 = hdr[1];
    for (const char* name : kCachedAovs) {
        int32_t ch = 0;
        if (!in.read(reinterpret_cast<char*>(&ch), sizeof(ch)) || ch < 1 || ch > 4)
            return false;
        Aov& a = f.add(name, ch, std::string(name) == "variance");
        a.pixels.resize(size_t(f.width) * size_t(f.height) * size_t(ch));
        if (!in.read(reinterpret_cast<char*>(a.pixels.data()), std::streamsize(a.pixels.size() * sizeof(float))))
            return false;
    }
    return true;
}

}  // namespace nimbus
