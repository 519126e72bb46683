/* nimbus.h: the C ABI for embedding nimbus in applications (DCC plugins, bindings).
 *
 * C99, no dependency beyond <stddef.h> and <stdint.h>. The C++ wrapper is nimbus.hpp, the
 * Python module wraps it too; the reference with examples is docs/embedding.md.
 *
 * Objects. Scenes, cameras, lights, volumes, render sessions and frames (a finished render's
 * buffers) are opaque reference-counted handles. A handle is a 64-bit number, not a pointer: it
 * names a slot in a registry and carries the object's type and the slot's generation, so a
 * handle of the wrong type, a released handle or a made-up number is detected and answered with
 * an error code; it never crashes. Every create/load/get that returns a handle returns it with a
 * reference the caller owns and gives back with nimbus_release. A scene holds its own references
 * to the camera, lights and volumes attached to it, so releasing them after attaching is fine.
 *
 * Parameters. Each object's parameters are the keys of its object in the JSON scene format
 * (docs/scene-format.md), with dots for nested keys: a light's "irradiance", a volume's
 * "medium.phase.g" or "source.file", a scene's "render.spp" or "output.file". They are checked
 * by the same code that reads scene files, at the time they are set: an unknown name, a value of
 * the wrong type or out of range is refused with the format's own message and leaves the
 * object unchanged. Checks that involve several objects (unique light names, a vdb volume's
 * file) run at nimbus_commit.
 *
 * Commit. Rendering reads a snapshot of the scene taken by nimbus_commit(scene): later edits are
 * not seen by a render until the next commit, and a render in progress is never affected.
 *
 * Errors. Every function returns a NimbusStatus; NIMBUS_OK is 0. On failure,
 * nimbus_last_error() returns a one-line message for the calling thread (valid until that
 * thread's next nimbus call). No C++ exception crosses this interface, and nimbus never
 * terminates the process.
 *
 * Threads. Every function may be called from any thread. Parameter edits and commits of one
 * scene are serialised internally. Progress callbacks run on a render thread, one at a time.
 */
#ifndef NIMBUS_H
#define NIMBUS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Incremented on every incompatible change of this header; nimbus_abi_version() returns the
 * value the library was built with. */
#define NIMBUS_ABI_VERSION 1

#if defined(_WIN32)
#define NIMBUS_API __declspec(dllexport)
#else
#define NIMBUS_API __attribute__((visibility("default")))
#endif

typedef enum NimbusStatus {
    NIMBUS_OK = 0,
    NIMBUS_ERROR_INVALID_ARGUMENT = 1,  /* a NULL pointer, a negative count, a bad enum value */
    NIMBUS_ERROR_INVALID_HANDLE = 2,    /* 0, released, or never a handle */
    NIMBUS_ERROR_WRONG_HANDLE_TYPE = 3, /* e.g. a light where a scene is expected */
    NIMBUS_ERROR_UNKNOWN_PARAMETER = 4, /* not a key of this object in the scene format */
    NIMBUS_ERROR_WRONG_TYPE = 5,        /* e.g. a string for "fov" */
    NIMBUS_ERROR_BAD_INPUT = 6,         /* out of range, missing file / grid / plugin, bad JSON (CLI exit 2) */
    NIMBUS_ERROR_NOT_COMMITTED = 7,     /* rendering a scene that was never committed */
    NIMBUS_ERROR_BUSY = 8,              /* the session is rendering */
    NIMBUS_ERROR_CANCELLED = 9,         /* the render was cancelled */
    NIMBUS_ERROR_TIMEOUT = 10,          /* nimbus_session_wait: still rendering */
    NIMBUS_ERROR_NOT_FOUND = 11,        /* no such AOV, index out of range, no frame yet */
    NIMBUS_ERROR_RENDER_FAILED = 12,    /* a failure that is not the input's fault (CLI exit 1) */
    NIMBUS_ERROR_OUT_OF_MEMORY = 13,
    NIMBUS_ERROR_BUFFER_TOO_SMALL = 14, /* nimbus_scene_to_json: *length says what is needed */
    NIMBUS_ERROR_INTERNAL = 15          /* a bug: please report the message */
} NimbusStatus;

typedef enum NimbusHandleType {
    NIMBUS_TYPE_SCENE = 1,
    NIMBUS_TYPE_CAMERA = 2,
    NIMBUS_TYPE_LIGHT = 3,
    NIMBUS_TYPE_VOLUME = 4,
    NIMBUS_TYPE_SESSION = 5,
    NIMBUS_TYPE_FRAME = 6
} NimbusHandleType;

/* Handles. The aliases document intent; all are the same integer type, so any handle can be
 * passed anywhere and a mismatch is reported at run time (NIMBUS_ERROR_WRONG_HANDLE_TYPE). */
typedef uint64_t NimbusHandle;
typedef NimbusHandle NimbusScene;
typedef NimbusHandle NimbusCamera;
typedef NimbusHandle NimbusLight;
typedef NimbusHandle NimbusVolume;
typedef NimbusHandle NimbusSession;
typedef NimbusHandle NimbusFrame;
#define NIMBUS_NULL_HANDLE ((NimbusHandle)0)

/* ---- library ------------------------------------------------------------------------------ */

NIMBUS_API const char* nimbus_version(void); /* "0.1.0" */
NIMBUS_API int nimbus_abi_version(void);     /* NIMBUS_ABI_VERSION of the library */
/* The calling thread's message for its last failed call ("" if none). */
NIMBUS_API const char* nimbus_last_error(void);
/* "NIMBUS_ERROR_BUSY" etc.; "unknown status" for other values. */
NIMBUS_API const char* nimbus_status_name(NimbusStatus status);

/* ---- handles ------------------------------------------------------------------------------ */

NIMBUS_API NimbusStatus nimbus_retain(NimbusHandle handle);
/* Gives back one reference; the handle is invalid once its count reaches 0. Releasing a session
 * that is rendering cancels the render and waits for it (not from its own progress callback). */
NIMBUS_API NimbusStatus nimbus_release(NimbusHandle handle);
NIMBUS_API NimbusStatus nimbus_handle_type(NimbusHandle handle, NimbusHandleType* type);

/* ---- parameters (cameras, lights, volumes, scenes) ------------------------------------------ */

/* Numbers: ints and floats are both JSON numbers; an "int" key accepts an integer-valued float,
 * as in the file format. */
NIMBUS_API NimbusStatus nimbus_set_int(NimbusHandle object, const char* name, int64_t value);
NIMBUS_API NimbusStatus nimbus_set_float(NimbusHandle object, const char* name, double value);
/* vec3 and RGB keys ("from", "irradiance", "medium.sigma_s"). */
NIMBUS_API NimbusStatus nimbus_set_float3(NimbusHandle object, const char* name, double x, double y, double z);
/* Arrays of numbers: "resolution" (2), "crop" (4), "size" (2), "transform" (16, row-major). */
NIMBUS_API NimbusStatus nimbus_set_floats(NimbusHandle object, const char* name, const double* values, size_t count);
NIMBUS_API NimbusStatus nimbus_set_string(NimbusHandle object, const char* name, const char* value);
/* Lists of strings ("output.aovs"). */
NIMBUS_API NimbusStatus nimbus_set_strings(NimbusHandle object, const char* name, const char* const* values,
                                           size_t count);
/* Any value as JSON text, e.g. the object form of "transform" or a whole "medium". */
NIMBUS_API NimbusStatus nimbus_set_json(NimbusHandle object, const char* name, const char* json);
/* Removes a key: it takes its default again. Removing an absent key is not an error. */
NIMBUS_API NimbusStatus nimbus_unset(NimbusHandle object, const char* name);

/* ---- scenes ------------------------------------------------------------------------------- */

/* An empty scene with a default camera; commit it before rendering. */
NIMBUS_API NimbusStatus nimbus_scene_create(NimbusScene* scene);
/* Reads a JSON scene file (relative vdb paths resolve against its directory), validates and
 * commits it. Its camera, lights and volumes become objects reachable with the getters below. */
NIMBUS_API NimbusStatus nimbus_scene_load_file(const char* path, NimbusScene* scene);
/* The same from JSON text; base_path (may be NULL) anchors relative vdb paths like a file's. */
NIMBUS_API NimbusStatus nimbus_scene_load_json(const char* json, const char* base_path, NimbusScene* scene);

NIMBUS_API NimbusStatus nimbus_scene_set_camera(NimbusScene scene, NimbusCamera camera);
NIMBUS_API NimbusStatus nimbus_scene_get_camera(NimbusScene scene, NimbusCamera* camera);
NIMBUS_API NimbusStatus nimbus_scene_add_light(NimbusScene scene, NimbusLight light);
NIMBUS_API NimbusStatus nimbus_scene_remove_light(NimbusScene scene, NimbusLight light);
NIMBUS_API NimbusStatus nimbus_scene_light_count(NimbusScene scene, size_t* count);
NIMBUS_API NimbusStatus nimbus_scene_get_light(NimbusScene scene, size_t index, NimbusLight* light);
NIMBUS_API NimbusStatus nimbus_scene_add_volume(NimbusScene scene, NimbusVolume volume);
NIMBUS_API NimbusStatus nimbus_scene_remove_volume(NimbusScene scene, NimbusVolume volume);
NIMBUS_API NimbusStatus nimbus_scene_volume_count(NimbusScene scene, size_t* count);
NIMBUS_API NimbusStatus nimbus_scene_get_volume(NimbusScene scene, size_t index, NimbusVolume* volume);

/* On a scene: validates the whole scene and makes it the snapshot renders read. On a camera,
 * light or volume: validates that object alone (a scene's commit reads its current values). */
NIMBUS_API NimbusStatus nimbus_commit(NimbusHandle object);
/* The committed scene as a complete JSON document (every key, defaults included), the exact
 * input of `nimbus render`. Writes at most capacity bytes including the NUL; *length (may be
 * NULL) receives the size needed without the NUL. buffer may be NULL with capacity 0. */
NIMBUS_API NimbusStatus nimbus_scene_to_json(NimbusScene scene, char* buffer, size_t capacity, size_t* length);

/* ---- cameras, lights, volumes -------------------------------------------------------------- */

NIMBUS_API NimbusStatus nimbus_camera_create(NimbusCamera* camera);
/* type: "distant", "point", "spot", "rect", "sphere" or "environment". */
NIMBUS_API NimbusStatus nimbus_light_create(const char* type, NimbusLight* light);
/* source_type: "vdb", "procedural" or "plugin"; then set "source.file", "source.generator",
 * "source.path"... */
NIMBUS_API NimbusStatus nimbus_volume_create(const char* source_type, NimbusVolume* volume);

/* ---- rendering ---------------------------------------------------------------------------- */

/* fraction in [0, 1]; return non-zero to go on, 0 to cancel. */
typedef int (*NimbusProgressCallback)(float fraction, void* user_data);

typedef enum NimbusSessionState {
    NIMBUS_SESSION_IDLE = 0, /* never rendered */
    NIMBUS_SESSION_RUNNING = 1,
    NIMBUS_SESSION_FINISHED = 2, /* the last render succeeded: nimbus_session_frame has it */
    NIMBUS_SESSION_FAILED = 3    /* failed or cancelled: nimbus_session_wait says which */
} NimbusSessionState;

/* A session renders a scene's committed snapshot (taken when each render starts). */
NIMBUS_API NimbusStatus nimbus_session_create(NimbusScene scene, NimbusSession* session);
/* NULL callback: none. Not while rendering (NIMBUS_ERROR_BUSY). */
NIMBUS_API NimbusStatus nimbus_session_set_progress_callback(NimbusSession session, NimbusProgressCallback callback,
                                                             void* user_data);
/* Renders on the calling thread (and nimbus's worker threads) and returns when done: NIMBUS_OK,
 * NIMBUS_ERROR_CANCELLED, or the render's error. NIMBUS_ERROR_BUSY if already rendering. */
NIMBUS_API NimbusStatus nimbus_session_render(NimbusSession session);
/* Starts the render in the background and returns at once. */
NIMBUS_API NimbusStatus nimbus_session_start(NimbusSession session);
/* Waits up to timeout_seconds (< 0: for ever) for a background render: its status, or
 * NIMBUS_ERROR_TIMEOUT while it runs. Also answers for a finished synchronous render. */
NIMBUS_API NimbusStatus nimbus_session_wait(NimbusSession session, double timeout_seconds);
/* Asks the running render to stop; it stops at its next tile (nimbus_session_wait then answers
 * NIMBUS_ERROR_CANCELLED). Not an error when nothing is running. Callable from any thread. */
NIMBUS_API NimbusStatus nimbus_session_cancel(NimbusSession session);
NIMBUS_API NimbusStatus nimbus_session_state(NimbusSession session, NimbusSessionState* state, float* progress);
/* The last successful render's frame, with a new reference. */
NIMBUS_API NimbusStatus nimbus_session_frame(NimbusSession session, NimbusFrame* frame);

/* ---- frames: a finished render's AOVs ------------------------------------------------------ */

typedef struct NimbusAov {
    const char* name;       /* "beauty", "L0", "L1", "L2plus", "alpha", "depth", "variance", "light_<name>" */
    const float* pixels;    /* width * height * channels floats, rows from the top, channels interleaved */
    int32_t width, height;  /* the full frame */
    int32_t channels;       /* 4 for beauty (RGBA), 3 for colour AOVs, 1 for data AOVs */
    int32_t is_data;        /* 1: alpha, depth, variance (not colour) */
    int32_t x0, y0, x1, y1; /* data window (crop) [x0, x1) x [y0, y1); pixels outside it are 0 */
} NimbusAov;

/* name and pixels stay valid until the frame's last reference is released. */
NIMBUS_API NimbusStatus nimbus_frame_aov_count(NimbusFrame frame, size_t* count);
NIMBUS_API NimbusStatus nimbus_frame_aov(NimbusFrame frame, size_t index, NimbusAov* aov);
NIMBUS_API NimbusStatus nimbus_frame_find_aov(NimbusFrame frame, const char* name, NimbusAov* aov);
NIMBUS_API NimbusStatus nimbus_frame_seconds(NimbusFrame frame, double* seconds);
/* Writes the rendered scene's outputs (output.file EXR with output.aovs, output.preview PNG)
 * exactly as `nimbus render` does. */
NIMBUS_API NimbusStatus nimbus_frame_write_outputs(NimbusFrame frame);

#ifdef __cplusplus
}
#endif

#endif /* NIMBUS_H */
