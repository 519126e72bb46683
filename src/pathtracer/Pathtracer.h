// Pathtracer.h: "method": "pathtrace", nimbus's unbiased reference (kernels/pathtrace.cl,
// docs/pathtracer.md). The host side: device selection, scene upload, progressive rendering in
// launches of a few samples per pixel with a running estimate (Skanberg sec. 6.9), stopping
// rules, checkpoints and the AOVs by scattering order.
#pragma once

#include "../render/Film.h"
#include "../render/RenderContext.h"
#include "../render/Renderer.h"
#include "PathtraceOptions.h"

#include <string>
#include <vector>

namespace nimbus {

// Renders ctx's scene into `film`. The film's AOVs are filled by name (beauty, L0, L1, L2plus,
// alpha, depth, variance, light_<name>); a film with no AOVs gets all of them, sized from the
// camera and its crop. Stops after scene.render.spp samples per pixel (spp 0: after the launch
// that brings the beauty's relMSE, estimated from its variance, to scene.render.noise_target) or
// after the launch that crosses scene.render.time_limit seconds, whichever comes first. Paths have
// at most scene.render.max_depth scattering events (0: unbounded). Throws Error (no OpenCL
// device, kernel build failure), Cancelled (options.progress returned false or options.cancel).
void renderPathtrace(const RenderContext& ctx, Film& film, const RenderOptions& options,
                     const PathtraceOptions& pt = {});

// One line per OpenCL device, "index: name [type, ...] on platform (...)", for `nimbus devices`.
// Throws Error when there is no OpenCL platform.
std::vector<std::string> listOpenClDevices();

}  // namespace nimbus
