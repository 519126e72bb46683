// ReferenceCache.h: the converged reference of `nimbus compare`, cached on disk between runs.
// The file is named by a hash of the reference scene's complete JSON document (every key,
// defaults included, the outputs left out), so any change to the scene or to the reference's
// time budget renders a new one. Private to src/compare.
#pragma once

#include "../render/Film.h"
#include "../scene/Scene.h"

#include <string>

namespace nimbus {

// Where the reference for `refScene` is cached: in cacheDir when given, else in compare/ under
// the first of $NIMBUS_CACHE_DIR, $XDG_CACHE_HOME/nimbus, ~/.cache/nimbus that is set (or
// /tmp/nimbus-cache).
std::string referenceCachePath(const Scene& refScene, const std::string& cacheDir);
// The AOVs the comparison reads, as a flat binary file (magic, size, AOVs); loadReference
// returns false where the file is missing or not one of these.
void saveReference(const Film& f, const std::string& path);
bool loadReference(const std::string& path, Film& f);

}  // namespace nimbus
