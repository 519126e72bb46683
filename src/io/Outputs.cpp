#include "Outputs.h"

#include "../core/Error.h"
#include "../engine/Renderer.h"
#include "ExrWriter.h"
#include "Preview.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <unistd.h>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

std::string where(const Scene& scene)
{
    return scene.sourcePath.empty() ? std::string("scene") : scene.sourcePath;
}

void checkWritable(const Scene& scene, const std::string& path, const std::string& key)
{
    if (path.empty())
        throw InputError(where(scene) + ": " + key + ": empty path");
    fs::path p(path);
    if (fs::is_directory(p))
        throw InputError(where(scene) + ": " + key + ": '" + path + "' is a directory");
    // Walk up to the first ancestor that exists: it must be a writable directory.
    fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
    std::error_code ec;
    fs::path existing = dir;
    while (!existing.empty() && !fs::exists(existing, ec))
        existing = existing.parent_path();
    if (existing.empty())
        existing = ".";
    if (!fs::is_directory(existing, ec))
        throw InputError(where(scene) + ": " + key + ": cannot create '" + dir.string() + "': '" + existing.string() +
                         "' is not a directory");
    if (::access(existing.c_str(), W_OK) != 0)
        throw InputError(where(scene) + ": " + key + ": cannot write to '" + existing.string() +
                         "': " + std::strerror(errno));
}

}  // namespace

void checkOutputs(const Scene& scene)
{
    checkWritable(scene, scene.output.file, "output.file");
    if (!scene.output.preview.empty())
        checkWritable(scene, scene.output.preview, "output.preview");
    std::vector<std::string> available = aovNames(scene, scene.render.method);
    for (size_t i = 0; i < scene.output.aovs.size(); ++i) {
        const std::string& name = scene.output.aovs[i];
        if (std::find(available.begin(), available.end(), name) == available.end()) {
            std::string list;
            for (auto& a : available)
                list += (list.empty() ? "" : ", ") + a;
            throw InputError(where(scene) + ": output.aovs[" + std::to_string(i) + "]: method '" +
                             methodName(scene.render.method) + "' has no AOV '" + name + "' (available: " + list + ")");
        }
    }
}

void selectAovs(const Scene& scene, Film& film)
{
    if (scene.output.aovs.empty())
        return;
    std::vector<Aov> kept;
    if (Aov* beauty = film.find("beauty"))
        kept.push_back(std::move(*beauty));
    for (const std::string& name : scene.output.aovs) {
        if (name == "beauty")
            continue;
        if (Aov* a = film.find(name))
            kept.push_back(std::move(*a));
    }
    film.aovs = std::move(kept);
}

void writeOutputs(const Scene& scene, const Film& film)
{
    writeExr(film, scene.output.file);
    if (!scene.output.preview.empty())
        writePreview(film, scene.output.preview);
}

}  // namespace nimbus
