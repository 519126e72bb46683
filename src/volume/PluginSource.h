// PluginSource.h: volume sources of type "plugin": a third-party procedural in a shared library
// (the C entry points of src/abi/nimbus_volume_plugin.h), sampled into an OpenVDB density grid
// so that it takes the same path to the renderer as a VDB file or a built-in generator.
//
// Why a grid and not a callback at render time: the integrators sample density billions of
// times per frame from many threads and build majorant bricks and deep shadow maps from it; one
// pass over a voxel lattice at load time costs the plugin a few million calls and makes plugin
// volumes exactly as fast, deterministic and clampable as VDB volumes (production renderers
// that accept "sample(position)" plugins cache them the same way).
#pragma once

#include "Procedural.h"  // VdbFloatGrid, without OpenVDB's headers

#include <memory>
#include <string>
#include <vector>

namespace nimbus {

class StopFlag;

// Loads source.pluginPath, runs init(source.pluginParams), bounds, samples the lattice in 8^3
// blocks on all cores, runs cleanup and unloads the library. Returns a FloatGrid named
// "density" (fog volume, voxel size and placement from the plugin's bounds) and appends a
// description to gridsRead. keyPath names the source ("scene.json: volumes[0].source"); every
// failure (library not found, not a nimbus plugin, missing symbol, wrong interface version,
// init / bounds / sample failure, bad bounds) throws InputError "<keyPath>.path: <why>".
//
// The library is searched: an absolute path as is; a path with a '/' against sceneDir, then the
// working directory; a bare name in each directory of $NIMBUS_PLUGIN_PATH (':'-separated), then
// sceneDir, then the dynamic linker's own search (LD_LIBRARY_PATH, ld.so.cache). A bare name
// without ".so" is also tried as "lib<name>.so".
//
// `stop` (may be null) is polled before each block: once raised, the blocks stop, what was
// sampled is freed, cleanup runs and Cancelled is thrown. The plugin's own init and bounds are
// not interrupted.
std::shared_ptr<VdbFloatGrid> makePluginGrid(const VolumeSource& source, const std::string& sceneDir,
                                             const std::string& keyPath, std::vector<std::string>& gridsRead,
                                             const StopFlag* stop = nullptr);

}  // namespace nimbus
