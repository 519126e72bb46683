// Outputs.h: what a render leaves on disk: the EXR with the requested AOVs and the preview.
#pragma once

#include "../render/Film.h"
#include "../scene/Scene.h"

#include <string>

namespace nimbus {

// Checks, before any heavy work, that the scene's output paths can be written: not empty; after
// their symlinks, nothing or a regular file (not a directory, device, FIFO or socket); not any
// file the render reads (the scene, a VDB file, a shader, a plugin: compared by inode); the
// preview not the EXR itself; the parent directory existing or creatable, and writable. Also
// that output.aovs names AOVs the method produces. Throws InputError naming the file and key.
void checkOutputs(const Scene& scene);

// Keeps only the AOVs listed in scene.output.aovs (beauty always), in the listed order.
void selectAovs(const Scene& scene, Film& film);

// Writes the EXR (and the preview PNG if one is set), each atomically.
void writeOutputs(const Scene& scene, const Film& film);

}  // namespace nimbus
