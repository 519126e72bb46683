// Renderer.h: the entry point: Scene in, Film out. The CLI, the C ABI and the Python module
// all call this; nothing here parses files.
#pragma once

#include "../scene/Scene.h"
#include "Film.h"
#include "RenderPlan.h"
#include "../pathtracer/PathtraceOptions.h"

#include <atomic>
#include <functional>
#include <stdexcept>

namespace nimbus {

struct RenderOptions {
    // Called from worker threads as tiles finish, with the fraction done; return false to
    // cancel (the render then throws Cancelled).
    std::function<bool(float fraction)> progress;
    const std::atomic<bool>* cancel = nullptr;
    // The film holds the beauty and the AOVs scene.output.aovs names, not every AOV of the
    // method (callers that write only those: the CLI). Off, a frame has them all.
    bool outputAovsOnly = false;
    // Method "pathtrace" only: device, checkpoints, statistics.
    PathtraceOptions pathtrace;
};

class Cancelled : public std::runtime_error {
public:
    Cancelled() : std::runtime_error("render cancelled") {}
};

struct RenderResult {
    Film film;
    RenderPlan plan;
    double seconds = 0;
};

// Renders the scene with scene.render.method. Throws InputError for bad input, Error for
// render failures, Cancelled when cancelled.
RenderResult render(const Scene& scene, const RenderOptions& options = {});

// The plan alone (loads the volumes, builds no shadow maps): `nimbus info`.
RenderPlan planRender(const Scene& scene);

// Every AOV name a method can produce for this scene, in output order.
std::vector<std::string> aovNames(const Scene& scene, Method method);

// Sizes the film for the camera (crop = data window) and adds every AOV of the method, or with
// outputAovsOnly the beauty and those scene.output.aovs names (all where it is empty).
void setupFilm(Film& film, const Scene& scene, Method method, bool outputAovsOnly = false);

}  // namespace nimbus
