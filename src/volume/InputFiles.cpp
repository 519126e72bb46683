#include "InputFiles.h"

#include "../core/Error.h"
#include "VolumeShader.h"

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <system_error>

namespace nimbus {

namespace fs = std::filesystem;

std::vector<std::string> searchPathDirs(const char* variable)
{
    std::vector<std::string> dirs;
    if (const char* env = std::getenv(variable)) {
        std::stringstream list(env);
        std::string dir;
        while (std::getline(list, dir, ':'))
            if (!dir.empty())
                dirs.push_back(dir);
    }
    return dirs;
}

std::vector<std::string> sceneInputFiles(const Scene& scene)
{
    std::vector<std::string> files;
    auto addIfExists = [&](const std::string& path) {
        std::error_code ec;
        if (!path.empty() && fs::exists(path, ec))
            files.push_back(path);
    };
    addIfExists(scene.sourcePath);
    const std::string sceneDir =
        scene.sourcePath.empty() ? std::string() : fs::path(scene.sourcePath).parent_path().string();
    for (const Volume& volume : scene.volumes) {
        if (volume.source.type == SourceType::Vdb)
            addIfExists(resolveVdbPath(volume.source.file, sceneDir));
        if (volume.source.type == SourceType::Plugin)
            for (const std::string& candidate : pluginCandidates(volume.source.pluginPath, sceneDir))
                addIfExists(candidate);
        try {
            addIfExists(findShader(volume.shader, sceneDir, "").path);
        } catch (const InputError&) {
            // Not found: the volume's load says so, naming its key.
        }
    }
    // Mesh files and the depth-map holdout (resolved by the JSON loader, as VDB files are).
    for (const Geometry& g : scene.geometry)
        if (g.type == GeometryType::Mesh)
            addIfExists(g.file);
    addIfExists(scene.camera.holdoutDepth.file);
    for (const Light& l : scene.lights)
        addIfExists(l.map);
    return files;
}

}  // namespace nimbus
