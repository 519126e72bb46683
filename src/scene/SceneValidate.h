// SceneValidate.h: the range checks every Scene passes before anything renders it, and the
// one-line message format of scene input errors.
//
// The JSON loader checks types and key names while parsing and then calls validateScene; API
// clients (C ABI, Python, Blender) call validateScene on the Scene they built. Both report a
// problem the same way, named by the scene file's key path, so that a user who built a scene
// through the API reads the same parameter names as the documentation (docs/scene-format.md).
#pragma once

#include "Scene.h"

#include <string>

namespace nimbus {

// The largest extinction sigma_t = (sigma_s + sigma_a) * density_scale * density, 1/m, that
// nimbus renders (docs/volumes.md, "Extinction range"). Float holds 3.4e38; the marchers form
// products of sigma_t with step lengths, radiance and sums of both, so 1e30 keeps eight orders
// of headroom, and is twenty-five orders beyond the densest smoke (about 1e4 1/m).
constexpr double kMaxExtinction = 1e30;
// The finest render.step (voxels): a thousandth of a voxel, 500 times finer than the default.
constexpr double kMinRenderStep = 1e-3;

// max over channels of (sigma_s + sigma_a) * density_scale, in double (the float product of
// huge values is already inf): the medium's extinction at density 1, 1/m.
double maxExtinctionAtDensityOne(const Medium& m);

// Throws InputError "<file>: <keyPath>: <what>", one line. An empty file drops the "<file>: "
// prefix (a scene built in memory); an empty keyPath drops "<keyPath>: ".
[[noreturn]] void throwSceneError(const std::string& file, const std::string& keyPath, const std::string& what);

// Checks every value against its documented range (docs/scene-format.md): finite numbers,
// non-negative radiometric quantities, non-degenerate camera, directions and transforms,
// unique light names that can be AOV names. Throws InputError naming scene.sourcePath and the
// key path of the first offending value.
void validateScene(const Scene& scene);

// Fills empty light names with their index ("0", "1", ...) and empty volume names with
// "volume<i>", the defaults the JSON format gives them; for API clients that leave names empty.
void applyDefaultNames(Scene& scene);

}  // namespace nimbus
