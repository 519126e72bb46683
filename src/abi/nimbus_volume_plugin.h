/* nimbus_volume_plugin.h: the C entry points of a third-party volume procedural.
 *
 * A scene names a shared library as a volume source:
 *
 *     "source": { "type": "plugin", "path": "libnimbus_torus.so",
 *                 "params": { "major_radius": 1.5, "seed": 7 } }
 *
 * and nimbus loads it (dlopen), builds one density grid from it and unloads it. The entry points
 * follow the production volume-plugin pattern (Arnold's volume_init / volume_create /
 * volume_sample / volume_cleanup, RenderMan's RixVolume): init with the parameters, ask the
 * bounds and the voxel size, sample, clean up. Full reference with an example:
 * docs/embedding.md, "Volume procedurals"; a complete plugin: plugins/procedurals/torus.c.
 *
 * The library exports, with C linkage and default visibility:
 *
 *   required  int   nimbus_volume_plugin_version(void)  returns NIMBUS_VOLUME_PLUGIN_VERSION
 *   required  void* nimbus_volume_init(...)             the plugin's state, NULL on failure
 *   required  int   nimbus_volume_bounds(...)           box and voxel size, 0 on success
 *   required  int   nimbus_volume_sample(...)           densities at points, 0 on success
 *   required  void  nimbus_volume_cleanup(void*)        frees the state
 *   optional  int   nimbus_volume_block_empty(...)      1 if a box is certainly empty
 *
 * Space and units. Every position is in the volume's own space, in metres; the scene's volume
 * "transform" places that space in the world, as for a VDB file. nimbus samples the density on
 * the voxel lattice x = i * voxel_size (i integer, voxel centres, as OpenVDB's linear transform)
 * covering [min, max], and from then on treats the grid exactly like a VDB density grid
 * (trilinear interpolation, clamping of negative / NaN values, the medium's sigma_s and sigma_a
 * per unit density).
 *
 * Threads. nimbus_volume_sample and nimbus_volume_block_empty are called concurrently from
 * several threads with the same state and must be thread-safe (read-only state is). init,
 * bounds and cleanup are called once each, from one thread, in that order; cleanup is called
 * whenever init succeeded, also when bounds or sampling failed.
 *
 * Errors. A failing call writes a one-line, NUL-terminated message into error (at most
 * error_size bytes, error_size >= 256) and returns NULL (init) or non-zero. nimbus reports it as
 * an input error naming the scene key, e.g. "scene.json: volumes[0].source.path: libfoo.so:
 * init failed: params.radius must be > 0". A plugin must never abort the process or throw a C++
 * exception across these functions.
 */
#ifndef NIMBUS_VOLUME_PLUGIN_H
#define NIMBUS_VOLUME_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The version of this interface; a plugin built against another version is refused. */
#define NIMBUS_VOLUME_PLUGIN_VERSION 1

#if defined(_WIN32)
#define NIMBUS_VOLUME_PLUGIN_EXPORT __declspec(dllexport)
#else
#define NIMBUS_VOLUME_PLUGIN_EXPORT __attribute__((visibility("default")))
#endif

/* The region to sample, in the volume's space (metres). */
typedef struct NimbusVolumeBounds {
    double min[3];
    double max[3];
    double voxel_size; /* lattice spacing, metres, > 0 */
} NimbusVolumeBounds;

/* The scene's "params", as text: numbers are written as JSON writes them ("0.5", "7"). */
typedef struct NimbusVolumeParam {
    const char* name;
    const char* value;
} NimbusVolumeParam;

typedef int (*NimbusVolumePluginVersionFn)(void);
/* params[0..count) are valid only during the call. Returns the plugin's state (any non-NULL
 * pointer), or NULL with a message in error. An unknown parameter name should be an error. */
typedef void* (*NimbusVolumeInitFn)(const NimbusVolumeParam* params, size_t count, char* error, size_t error_size);
/* The box that holds every non-zero density and the voxel size to sample it with. */
typedef int (*NimbusVolumeBoundsFn)(void* state, NimbusVolumeBounds* bounds, char* error, size_t error_size);
/* Densities (>= 0, per unit of the medium's coefficients) at count points; positions holds
 * x, y, z for each point. nimbus calls it with up to 512 points at a time (an 8^3 block). */
typedef int (*NimbusVolumeSampleFn)(void* state, const double* positions, size_t count, float* densities, char* error,
                                    size_t error_size);
/* Optional, for sparse procedurals: 1 if the density is zero everywhere in the closed box
 * [min, max], 0 if it may not be (the block is then sampled). The "ray extents" of production
 * plugins, asked per 8^3 block so that empty space costs no samples. */
typedef int (*NimbusVolumeBlockEmptyFn)(void* state, const double min[3], const double max[3]);
typedef void (*NimbusVolumeCleanupFn)(void* state);

#ifdef __cplusplus
}
#endif

#endif /* NIMBUS_VOLUME_PLUGIN_H */
