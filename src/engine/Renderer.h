// Renderer.h: the entry point: Scene in, Film out. The CLI, the C ABI and the Python module all
// call this; nothing here parses files.
//
// A render is: check the scene; the planning pass (load the volumes, the shared plan, the
// integrator's part: an immutable RenderPlan); the context's shadow maps where the integrator
// needs them; the integrator built and driven (camera-ray integrators by the tile driver, the
// others on their own), through the registry (IntegratorRegistry.h). Stage times and sizes go to
// RenderStats.
#pragma once

#include "../pathtracer/Pathtracer.h"
#include "../render/Film.h"
#include "../render/RenderControl.h"
#include "../render/RenderPlan.h"
#include "../render/RenderStats.h"
#include "../scene/Scene.h"
#include "../volume/VolumeData.h"

#include <string>
#include <vector>

namespace nimbus {

class ShadowMapCache;

struct RenderOptions : RenderControl {
    // The film holds the beauty and the AOVs scene.output.aovs names, not every AOV of the
    // method (callers that write only those: the CLI). Off, a frame has them all.
    bool outputAovsOnly = false;
    // Render one tile of the frame (docs/farm.md): tile tileIndex (1-based) of tileCount horizontal
    // bands of the data window, rows [y0 + (i - 1) H / N, y0 + i H / N) (integer division, H its
    // height); the film keeps the full frame's size with the band as its data window, and its
    // header says "tile" = "I/N". Every pixel draws the same samples as in the whole frame, so the
    // tiles put together are the frame bit for bit. 0: the whole data window.
    int tileIndex = 0, tileCount = 0;
    // Method "pathtrace" only: device, checkpoints, statistics.
    PathtraceOptions pathtrace;
    // A sequence's memory between frames (docs/sequences.md): volumes whose inputs did not change
    // are reused from the last render given the same cache. Null: everything is built anew.
    VolumeCache* volumeCache = nullptr;
    // The same for deep shadow maps (ShadowMapCache.h): reused where the light, the settings and
    // the (cached) volumes are unchanged. Null: built anew.
    ShadowMapCache* shadowMapCache = nullptr;
};

struct RenderResult {
    Film film;
    RenderPlan plan;
    RenderStats stats;
    double seconds = 0;
};

// Renders the scene with scene.render.method, at scene.render.frame: the frame tokens of its
// paths (FrameTokens.h) are replaced first. Throws InputError for bad input, Error for
// render failures, Cancelled when cancelled.
RenderResult render(const Scene& scene, const RenderOptions& options = {});

// The header of a frame (docs/output.md, "Metadata"): version, method, seed, settings, the scene
// as JSON, the statistics (render time in `seconds`, spp reached, samples, peak memory), whether
// it is `complete` (false: a checkpoint) and the camera as OpenEXR's worldToCamera and
// worldToNDC. render() adds it to its film and to every checkpoint's.
void addFrameMetadata(Film& film, const Scene& scene, double seconds, bool complete);

// Narrows the film's data window to tile `index` (1-based) of `count` (RenderOptions::tileIndex).
// Throws InputError naming --tile when the tile is out of range or has no rows.
void applyTile(Film& film, int index, int count);

// The plan alone (the planning pass: loads the volumes, builds no shadow map): `nimbus info`.
RenderPlan planRender(const Scene& scene);

// Every AOV name a method can produce for this scene, in output order.
std::vector<std::string> aovNames(const Scene& scene, Method method);

// Sizes the film for the camera (crop = data window) and adds every AOV of the method, or with
// outputAovsOnly the beauty and those scene.output.aovs names (all where it is empty).
void setupFilm(Film& film, const Scene& scene, Method method, bool outputAovsOnly = false);

}  // namespace nimbus
