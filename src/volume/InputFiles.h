// InputFiles.h: the files a render of a scene reads (the scene file, VDB files, shaders, volume
// plugins), found the way the loaders find them, so that an output path can be checked against
// every one of them before anything is written (docs/output.md, "Safe outputs").
#pragma once

#include "../scene/Scene.h"

#include <string>
#include <vector>

namespace nimbus {

// A volume's VDB path as the loader opens it. Relative paths are relative to the scene file's
// directory; a path the JSON loader already resolved (then relative to the working directory)
// is kept as it is.
std::string resolveVdbPath(const std::string& file, const std::string& sceneDir);

// The non-empty directories of a ':'-separated search path in the environment variable, in
// order ($NIMBUS_SHADER_PATH, $NIMBUS_PLUGIN_PATH); none when it is unset.
std::vector<std::string> searchPathDirs(const char* variable);

// The candidates for a plugin library path, in the loader's search order (PluginSource.h).
std::vector<std::string> pluginCandidates(const std::string& path, const std::string& sceneDir);

// Every existing file the render would read: the scene file, each volume's VDB file, its shader
// (a shader that cannot be found is left out: loading reports it) and each existing candidate of
// its plugin library, each mesh file and the depth-map holdout. Paths as found, not canonical:
// compare them by inode.
std::vector<std::string> sceneInputFiles(const Scene& scene);

}  // namespace nimbus
