#include "Outputs.h"

#include "../core/Error.h"
#include "../engine/Renderer.h"
#include "../volume/InputFiles.h"
#include "AtomicFile.h"
#include "ExrWriter.h"
#include "Preview.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <sys/stat.h>
#include <unistd.h>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

std::string where(const Scene& scene)
{
    return scene.sourcePath.empty() ? std::string("scene") : scene.sourcePath;
}

bool sameFile(const struct stat& a, const std::string& path)
{
    struct stat b;
    return ::stat(path.c_str(), &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

void checkWritable(const Scene& scene, const std::string& path, const std::string& key,
                   const std::vector<std::string>& inputs)
{
    auto fail = [&](const std::string& what) { return InputError(where(scene) + ": " + key + ": " + what); };
    if (path.empty())
        throw fail("empty path");
    // What is at the path after its symlinks: only a regular file may be replaced, and never one
    // the render reads (compared by device and inode, so hard links and "./x" spellings count).
    const std::string resolved = followSymlinks(path);
    const std::string kind = nonRegularKind(resolved);
    if (!kind.empty())
        throw fail("'" + path + "' is " + kind + "; nimbus writes only regular files");
    struct stat target;
    if (::stat(resolved.c_str(), &target) == 0)
        for (const std::string& input : inputs)
            if (sameFile(target, input))
                throw fail("'" + path + "' is an input of this render ('" + input + "'); writing it would destroy it");
    // Walk up to the first ancestor that exists: it must be a writable directory.
    fs::path p(resolved);
    fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
    std::error_code ec;
    fs::path existing = dir;
    while (!existing.empty() && !fs::exists(existing, ec))
        existing = existing.parent_path();
    if (existing.empty())
        existing = ".";
    if (!fs::is_directory(existing, ec))
        throw fail("cannot create '" + dir.string() + "': '" + existing.string() + "' is not a directory");
    if (::access(existing.c_str(), W_OK) != 0)
        throw fail("cannot write to '" + existing.string() + "': " + std::strerror(errno));
}

}  // namespace

std::string checkpointPath(const std::string& file)
{
    const fs::path path(file);
    fs::path name = path.stem();
    name += ".partial";
    name += path.extension();
    return (path.parent_path() / name).string();
}

PreviewOptions previewOptions(const Scene& scene)
{
    PreviewOptions options;
    options.view = scene.output.previewView;
    options.look = scene.output.previewLook;
    options.exposure = scene.output.exposure;
    return options;
}

void checkOutputs(const Scene& scene, bool checkpoints)
{
    const std::vector<std::string> inputs = sceneInputFiles(scene);
    checkWritable(scene, scene.output.file, "output.file", inputs);
    if (checkpoints)
        checkWritable(scene, checkpointPath(scene.output.file), "output.file (its checkpoint)", inputs);
    if (!scene.output.preview.empty()) {
        checkWritable(scene, scene.output.preview, "output.preview", inputs);
        std::error_code ec;
        if (fs::weakly_canonical(followSymlinks(scene.output.preview), ec) ==
            fs::weakly_canonical(followSymlinks(scene.output.file), ec))
            throw InputError(where(scene) + ": output.preview: '" + scene.output.preview +
                             "' is also output.file; the preview would replace the EXR");
    }
    if (!scene.output.deep.empty()) {
        checkWritable(scene, scene.output.deep, "output.deep", inputs);
        std::error_code ec;
        const fs::path deep = fs::weakly_canonical(followSymlinks(scene.output.deep), ec);
        for (const auto& [other, key] : {std::pair{scene.output.file, "output.file"},
                                         std::pair{scene.output.preview, "output.preview"}})
            if (!other.empty() && deep == fs::weakly_canonical(followSymlinks(other), ec))
                throw InputError(where(scene) + ": output.deep: '" + scene.output.deep + "' is also " + key +
                                 "; one would replace the other");
    }
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
    // The preview's config, view and look, checked now: after the render is too late (the EXR
    // would already be written and the run would end in a render failure).
    if (!scene.output.preview.empty() || !scene.output.previewView.empty() || !scene.output.previewLook.empty())
        checkPreviewSettings(previewOptions(scene), where(scene));
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
        writePreview(film, scene.output.preview, previewOptions(scene));
    if (!scene.output.deep.empty() && film.deep)
        writeDeepExr(film, scene.output.deep);
}

}  // namespace nimbus
