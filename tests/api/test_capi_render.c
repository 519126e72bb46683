/* test_capi_render.c: the C ABI used as documented: scenes built in code and from JSON render
 * the same image, AOVs are complete, background renders report progress, volume procedurals
 * load (and fail with the scene key named), outputs are written. */
#define _POSIX_C_SOURCE 200809L

#include "CapiTest.h"

#include <math.h>
#include <stdlib.h>
#include <unistd.h>

NimbusScene makeTestScene(int width, int height, int spp)
{
    NimbusScene scene = NIMBUS_NULL_HANDLE;
    NimbusCamera camera;
    NimbusLight sun;
    NimbusVolume sphere;
    const double resolution[2] = {width, height};
    OK(nimbus_scene_create(&scene));
    OK(nimbus_camera_create(&camera));
    OK(nimbus_set_float3(camera, "from", 0, 0, 4));
    OK(nimbus_set_float3(camera, "to", 0, 0, 0));
    OK(nimbus_set_float(camera, "fov", 35));
    OK(nimbus_set_floats(camera, "resolution", resolution, 2));
    OK(nimbus_scene_set_camera(scene, camera));
    OK(nimbus_release(camera)); /* the scene holds its own reference */

    OK(nimbus_light_create("distant", &sun));
    OK(nimbus_set_string(sun, "name", "key"));
    OK(nimbus_set_float3(sun, "direction", 0.5, -1, -0.3));
    OK(nimbus_set_float(sun, "irradiance", 3));
    OK(nimbus_scene_add_light(scene, sun));
    OK(nimbus_release(sun));

    OK(nimbus_volume_create("procedural", &sphere));
    OK(nimbus_set_string(sphere, "name", "ball"));
    OK(nimbus_set_string(sphere, "source.generator", "sphere"));
    OK(nimbus_set_float(sphere, "source.radius", 1.0));
    OK(nimbus_set_float(sphere, "source.voxel_size", 0.05));
    OK(nimbus_set_float3(sphere, "medium.sigma_s", 2, 2.2, 2.4));
    OK(nimbus_set_float(sphere, "medium.phase.g", 0.3));
    OK(nimbus_scene_add_volume(scene, sphere));
    OK(nimbus_release(sphere));

    OK(nimbus_set_int(scene, "render.spp", spp));
    OK(nimbus_set_int(scene, "render.threads", 2));
    OK(nimbus_commit(scene));
    return scene;
}

/* The same scene as JSON text. */
static const char* kSceneJson =
    "{\"camera\": {\"from\": [0, 0, 4], \"to\": [0, 0, 0], \"fov\": 35, \"resolution\": [32, 24]},"
    " \"lights\": [{\"type\": \"distant\", \"name\": \"key\", \"direction\": [0.5, -1, -0.3], \"irradiance\": 3}],"
    " \"volumes\": [{\"name\": \"ball\", \"source\": {\"type\": \"procedural\", \"generator\": \"sphere\","
    " \"radius\": 1.0, \"voxel_size\": 0.05},"
    " \"medium\": {\"sigma_s\": [2, 2.2, 2.4], \"phase\": {\"g\": 0.3}}}],"
    " \"render\": {\"spp\": 2, \"threads\": 2}}";

static NimbusFrame renderFrame(NimbusScene scene)
{
    NimbusSession session;
    NimbusFrame frame = NIMBUS_NULL_HANDLE;
    OK(nimbus_session_create(scene, &session));
    OK(nimbus_session_render(session));
    OK(nimbus_session_frame(session, &frame));
    OK(nimbus_release(session)); /* the frame outlives its session */
    return frame;
}

/* Every AOV of two frames holds the same floats. */
static int sameFrames(NimbusFrame a, NimbusFrame b)
{
    size_t na = 0, nb = 0, i;
    OK(nimbus_frame_aov_count(a, &na));
    OK(nimbus_frame_aov_count(b, &nb));
    if (na != nb || na == 0)
        return 0;
    for (i = 0; i < na; ++i) {
        NimbusAov x, y;
        OK(nimbus_frame_aov(a, i, &x));
        OK(nimbus_frame_aov(b, i, &y));
        if (strcmp(x.name, y.name) || x.channels != y.channels || x.width != y.width || x.height != y.height ||
            memcmp(x.pixels, y.pixels, sizeof(float) * (size_t)x.width * x.height * x.channels))
            return 0;
    }
    return 1;
}

static void testVersion(void)
{
    CHECK(nimbus_abi_version() == NIMBUS_ABI_VERSION);
    CHECK(strlen(nimbus_version()) > 0);
    CHECK(strcmp(nimbus_status_name(NIMBUS_ERROR_BUSY), "NIMBUS_ERROR_BUSY") == 0);
}

static void testAovs(void)
{
    NimbusScene scene = makeTestScene(32, 24, 2);
    NimbusFrame frame = renderFrame(scene);
    const char* expected[] = {"beauty", "L0", "L1", "alpha", "depth", "light_key"};
    size_t count = 0, i;
    NimbusAov beauty, alpha;
    double seconds = -1;
    OK(nimbus_frame_aov_count(frame, &count));
    CHECK(count == 6);
    for (i = 0; i < count && i < 6; ++i) {
        NimbusAov a;
        OK(nimbus_frame_aov(frame, i, &a));
        CHECK(strcmp(a.name, expected[i]) == 0);
        CHECK(a.width == 32 && a.height == 24);
        CHECK(a.x0 == 0 && a.y0 == 0 && a.x1 == 32 && a.y1 == 24);
    }
    OK(nimbus_frame_find_aov(frame, "beauty", &beauty));
    CHECK(beauty.channels == 4 && !beauty.is_data);
    OK(nimbus_frame_find_aov(frame, "alpha", &alpha));
    CHECK(alpha.channels == 1 && alpha.is_data);
    /* The sphere covers the centre, not the corner. */
    CHECK(alpha.pixels[12 * 32 + 16] > 0.5f);
    CHECK(alpha.pixels[0] == 0.0f);
    CHECK(beauty.pixels[(12 * 32 + 16) * 4] > 0.0f && isfinite(beauty.pixels[(12 * 32 + 16) * 4]));
    CHECK(beauty.pixels[(12 * 32 + 16) * 4 + 3] == alpha.pixels[12 * 32 + 16]);
    OK(nimbus_frame_seconds(frame, &seconds));
    CHECK(seconds >= 0);
    OK(nimbus_release(frame));
    OK(nimbus_release(scene));
}

/* A tiny field of view renders finite pixels through the C ABI (issue 18, failure 4: an int
 * overflow in tile culling wrote out of bounds at fov 1e-10 and killed the host application). */
static void testTinyFieldOfView(void)
{
    const char* methods[2] = {"single", "wkb"};
    const double fovs[2] = {1e-10, 1e-30};
    int m, f;
    for (m = 0; m < 2; ++m)
        for (f = 0; f < 2; ++f) {
            NimbusScene scene = makeTestScene(16, 12, 1);
            NimbusCamera camera;
            NimbusFrame frame;
            NimbusAov beauty;
            int i, finite = 1;
            OK(nimbus_scene_get_camera(scene, &camera));
            OK(nimbus_set_float(camera, "fov", fovs[f]));
            OK(nimbus_release(camera));
            OK(nimbus_set_string(scene, "render.method", methods[m]));
            OK(nimbus_commit(scene));
            frame = renderFrame(scene);
            OK(nimbus_frame_find_aov(frame, "beauty", &beauty));
            for (i = 0; i < 16 * 12 * 4; ++i)
                finite = finite && isfinite(beauty.pixels[i]);
            CHECK(finite);
            OK(nimbus_release(frame));
            OK(nimbus_release(scene));
        }
}

/* Code, JSON text and the written-back JSON are one scene: the same floats. */
static void testSameSceneThreeWays(void)
{
    NimbusScene code = makeTestScene(32, 24, 2), json, roundTrip;
    NimbusFrame a, b, c;
    char* text;
    size_t length = 0;
    OK(nimbus_scene_load_json(kSceneJson, NULL, &json));
    CHECK_STATUS(nimbus_scene_to_json(code, NULL, 0, &length), NIMBUS_ERROR_BUFFER_TOO_SMALL);
    CHECK(length > 100);
    text = (char*)malloc(length + 1);
    OK(nimbus_scene_to_json(code, text, length + 1, &length));
    CHECK(text[length] == '\0');
    OK(nimbus_scene_load_json(text, NULL, &roundTrip));
    free(text);
    a = renderFrame(code);
    b = renderFrame(json);
    c = renderFrame(roundTrip);
    CHECK(sameFrames(a, b));
    CHECK(sameFrames(a, c));
    OK(nimbus_release(a));
    OK(nimbus_release(b));
    OK(nimbus_release(c));
    OK(nimbus_release(code));
    OK(nimbus_release(json));
    OK(nimbus_release(roundTrip));
}

/* Objects reached through a loaded scene edit it; a commit makes the edit visible. */
static void testEditLoadedScene(void)
{
    NimbusScene scene;
    NimbusLight light;
    NimbusFrame bright, dim;
    NimbusAov a, b;
    size_t count = 0;
    OK(nimbus_scene_load_json(kSceneJson, NULL, &scene));
    OK(nimbus_scene_light_count(scene, &count));
    CHECK(count == 1);
    OK(nimbus_scene_get_light(scene, 0, &light));
    bright = renderFrame(scene);
    OK(nimbus_set_float(light, "irradiance", 1.5));
    dim = renderFrame(scene); /* not committed yet: the same snapshot */
    CHECK(sameFrames(bright, dim));
    OK(nimbus_release(dim));
    OK(nimbus_commit(scene));
    dim = renderFrame(scene);
    OK(nimbus_frame_find_aov(bright, "L1", &a));
    OK(nimbus_frame_find_aov(dim, "L1", &b));
    /* L1 is linear in the light's irradiance. */
    CHECK(fabsf(b.pixels[(12 * 32 + 16) * 3] - 0.5f * a.pixels[(12 * 32 + 16) * 3]) <=
          1e-5f * a.pixels[(12 * 32 + 16) * 3]);
    OK(nimbus_release(light));
    OK(nimbus_release(bright));
    OK(nimbus_release(dim));
    OK(nimbus_release(scene));
}

typedef struct ProgressLog {
    int calls;
    float last;
    int monotonic;
} ProgressLog;

static int logProgress(float fraction, void* user)
{
    ProgressLog* log = (ProgressLog*)user;
    if (fraction < log->last)
        log->monotonic = 0;
    log->last = fraction;
    ++log->calls;
    return 1;
}

static void testBackgroundRender(void)
{
    NimbusScene scene = makeTestScene(64, 48, 2);
    NimbusSession session;
    NimbusSessionState state;
    NimbusFrame frame;
    ProgressLog log = {0, 0.0f, 1};
    float progress = -1;
    OK(nimbus_session_create(scene, &session));
    OK(nimbus_session_state(session, &state, &progress));
    CHECK(state == NIMBUS_SESSION_IDLE);
    CHECK_STATUS(nimbus_session_frame(session, &frame), NIMBUS_ERROR_NOT_FOUND);
    OK(nimbus_session_set_progress_callback(session, logProgress, &log));
    OK(nimbus_session_start(session));
    OK(nimbus_session_wait(session, -1.0));
    OK(nimbus_session_state(session, &state, &progress));
    CHECK(state == NIMBUS_SESSION_FINISHED && progress == 1.0f);
    CHECK(log.calls >= 12 && log.monotonic && log.last == 1.0f); /* 64 x 48 is 12 tiles of 16^2 */
    OK(nimbus_session_frame(session, &frame));
    OK(nimbus_release(frame));
    /* A second render on the same session. */
    OK(nimbus_session_render(session));
    OK(nimbus_session_wait(session, 0.0));
    OK(nimbus_release(session));
    OK(nimbus_release(scene));
}

static int cancelAtOnce(float fraction, void* user)
{
    (void)fraction;
    ++*(int*)user;
    return 0;
}

static void testCancelFromCallback(void)
{
    NimbusScene scene = makeTestScene(128, 96, 4);
    NimbusSession session;
    NimbusSessionState state;
    NimbusFrame frame;
    int calls = 0;
    OK(nimbus_session_create(scene, &session));
    OK(nimbus_session_set_progress_callback(session, cancelAtOnce, &calls));
    CHECK_STATUS(nimbus_session_render(session), NIMBUS_ERROR_CANCELLED);
    CHECK(calls >= 1 && calls < 48); /* stopped well before the 48 tiles */
    OK(nimbus_session_state(session, &state, NULL));
    CHECK(state == NIMBUS_SESSION_FAILED);
    CHECK_STATUS(nimbus_session_frame(session, &frame), NIMBUS_ERROR_NOT_FOUND);
    CHECK_STATUS(nimbus_session_wait(session, -1.0), NIMBUS_ERROR_CANCELLED);
    OK(nimbus_release(session));
    OK(nimbus_release(scene));
}

static void testPluginVolume(const TestPaths* paths)
{
    NimbusScene scene = makeTestScene(48, 32, 1);
    NimbusVolume ball, torus;
    NimbusFrame frame;
    NimbusAov alpha;
    NimbusSession session;
    int x, covered = 0;
    OK(nimbus_scene_get_volume(scene, 0, &ball));
    OK(nimbus_scene_remove_volume(scene, ball));
    OK(nimbus_release(ball));
    OK(nimbus_volume_create("plugin", &torus));
    OK(nimbus_set_string(torus, "source.path", paths->torusPlugin));
    OK(nimbus_set_float(torus, "source.params.major_radius", 1.0));
    OK(nimbus_set_float(torus, "source.params.voxel_size", 0.04));
    OK(nimbus_set_float(torus, "medium.sigma_s", 6));
    /* Face-on ring: the centre is empty, the ring is not. */
    OK(nimbus_set_json(torus, "transform", "{\"rotate\": [90, 1, 0, 0]}"));
    OK(nimbus_scene_add_volume(scene, torus));
    OK(nimbus_commit(scene));
    frame = renderFrame(scene);
    OK(nimbus_frame_find_aov(frame, "alpha", &alpha));
    CHECK(alpha.pixels[16 * 48 + 24] < 0.01f);
    for (x = 0; x < 48; ++x)
        covered += alpha.pixels[16 * 48 + x] > 0.3f;
    CHECK(covered >= 4);
    OK(nimbus_release(frame));

    /* Errors name the source's key path and say what went wrong. */
    OK(nimbus_session_create(scene, &session));
    OK(nimbus_set_string(torus, "source.path", "libnimbus_no_such_plugin.so"));
    OK(nimbus_commit(scene));
    CHECK_STATUS(nimbus_session_render(session), NIMBUS_ERROR_BAD_INPUT);
    CHECK_MESSAGE("volumes[0].source.path: cannot load volume plugin 'libnimbus_no_such_plugin.so'");
    OK(nimbus_set_string(torus, "source.path", paths->brokenPlugin));
    OK(nimbus_commit(scene));
    CHECK_STATUS(nimbus_session_render(session), NIMBUS_ERROR_BAD_INPUT);
    CHECK_MESSAGE("volumes[0].source.path");
    CHECK_MESSAGE("missing symbol nimbus_volume_sample");
    OK(nimbus_set_string(torus, "source.path", paths->torusPlugin));
    OK(nimbus_set_float(torus, "source.params.minor_radius", -1));
    OK(nimbus_commit(scene));
    CHECK_STATUS(nimbus_session_render(session), NIMBUS_ERROR_BAD_INPUT);
    CHECK_MESSAGE("volumes[0].source.path: libnimbus_torus.so: init failed");
    OK(nimbus_release(session));
    OK(nimbus_release(torus));
    OK(nimbus_release(scene));
}

static void testWriteOutputs(const TestPaths* paths)
{
    NimbusScene scene = makeTestScene(32, 24, 1);
    NimbusFrame frame;
    char exr[1024];
    const char* aovs[] = {"beauty", "alpha"};
    /* One file per process: ctest runs the plain and the ASan binary at once. */
    snprintf(exr, sizeof exr, "%s/capi_outputs_%ld.exr", paths->workDir, (long)getpid());
    unlink(exr);
    OK(nimbus_set_string(scene, "output.file", exr));
    OK(nimbus_set_strings(scene, "output.aovs", aovs, 2));
    OK(nimbus_commit(scene));
    frame = renderFrame(scene);
    OK(nimbus_frame_write_outputs(frame));
    CHECK(access(exr, R_OK) == 0);
    unlink(exr);
    OK(nimbus_release(frame));
    OK(nimbus_release(scene));
}

void testRender(const TestPaths* paths)
{
    testVersion();
    testAovs();
    testTinyFieldOfView();
    testSameSceneThreeWays();
    testEditLoadedScene();
    testBackgroundRender();
    testCancelFromCallback();
    testPluginVolume(paths);
    testWriteOutputs(paths);
}
