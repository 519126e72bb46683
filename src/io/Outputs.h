// Outputs.h: what a render leaves on disk: the EXR with the requested AOVs and the preview.
#pragma once

#include "../render/Film.h"
#include "../scene/Scene.h"
#include "Preview.h"

#include <string>

namespace nimbus {

// Where checkpoints of `file` go: "<stem>.partial<ext>" beside it ("out/f.0001.exr" ->
// "out/f.0001.partial.exr"), so that nothing at the final name looks finished before the render is.
std::string checkpointPath(const std::string& file);

// Checks, before any heavy work, that the scene's output paths can be written: not empty; after
// their symlinks, nothing or a regular file (not a directory, device, FIFO or socket); not any
// file the render reads (the scene, a VDB file, a shader, a plugin: compared by inode); the
// preview not the EXR itself; the parent directory existing or creatable, and writable. Also
// that output.aovs names AOVs the method produces; with `checkpoints`, the same of
// checkpointPath(output.file). Throws InputError naming the file and key. Then that the preview's
// OCIO config loads and has output.preview_view and output.preview_look (checkPreviewSettings).
void checkOutputs(const Scene& scene, bool checkpoints = false);

// Keeps only the AOVs listed in scene.output.aovs (beauty always), in the listed order.
void selectAovs(const Scene& scene, Film& film);

// The scene's preview controls (output.preview_view, .preview_look, .exposure) as options.
PreviewOptions previewOptions(const Scene& scene);

// Writes the EXR (and the preview PNG if one is set), each atomically.
void writeOutputs(const Scene& scene, const Film& film);

}  // namespace nimbus
