/* render_ring.c: a host application built out of tree against an installed nimbus (the C ABI
 * only, found by find_package(nimbus) or pkg-config). Renders a face-on smoke ring from a volume
 * procedural built the same way, writes the scene's outputs, and checks the picture: the ring's
 * centre is clear, the ring is not.
 *
 *   render_ring PLUGIN.so OUT.exr     exit 0 on success, 1 with a message otherwise
 */
#include "nimbus.h"

#include <stdio.h>

#define TRY(call)                                                                                                      \
    do {                                                                                                               \
        if ((call) != NIMBUS_OK) {                                                                                     \
            fprintf(stderr, "render_ring: %s: %s\n", #call, nimbus_last_error());                                      \
            return 1;                                                                                                  \
        }                                                                                                              \
    } while (0)

int main(int argc, char** argv)
{
    NimbusScene scene;
    NimbusCamera camera;
    NimbusLight sun;
    NimbusVolume ring;
    NimbusSession session;
    NimbusFrame frame;
    NimbusAov alpha;
    const int width = 48, height = 32;
    int x, covered = 0;
    if (argc != 3) {
        fprintf(stderr, "usage: render_ring PLUGIN.so OUT.exr\n");
        return 1;
    }
    if (nimbus_abi_version() != NIMBUS_ABI_VERSION) {
        fprintf(stderr, "render_ring: header ABI %d, library ABI %d\n", NIMBUS_ABI_VERSION, nimbus_abi_version());
        return 1;
    }
    TRY(nimbus_scene_create(&scene));
    TRY(nimbus_camera_create(&camera));
    TRY(nimbus_set_float3(camera, "from", 0, 0, 4));
    TRY(nimbus_set_float3(camera, "to", 0, 0, 0));
    TRY(nimbus_set_float(camera, "fov", 45));
    {
        const double resolution[2] = {width, height};
        TRY(nimbus_set_floats(camera, "resolution", resolution, 2));
    }
    TRY(nimbus_scene_set_camera(scene, camera));
    TRY(nimbus_release(camera));
    TRY(nimbus_light_create("distant", &sun));
    TRY(nimbus_set_float3(sun, "direction", 0.3, -1, -0.2));
    TRY(nimbus_set_float(sun, "irradiance", 3));
    TRY(nimbus_scene_add_light(scene, sun));
    TRY(nimbus_release(sun));
    TRY(nimbus_volume_create("plugin", &ring));
    TRY(nimbus_set_string(ring, "source.path", argv[1]));
    TRY(nimbus_set_float(ring, "source.params.major_radius", 1.0));
    TRY(nimbus_set_float(ring, "source.params.voxel_size", 0.04));
    TRY(nimbus_set_float(ring, "medium.sigma_s", 6));
    TRY(nimbus_set_json(ring, "transform", "{\"rotate\": [90, 1, 0, 0]}"));
    TRY(nimbus_scene_add_volume(scene, ring));
    TRY(nimbus_release(ring));
    TRY(nimbus_set_int(scene, "render.spp", 2));
    TRY(nimbus_set_string(scene, "output.file", argv[2]));
    TRY(nimbus_commit(scene));
    TRY(nimbus_session_create(scene, &session));
    TRY(nimbus_session_render(session));
    TRY(nimbus_session_frame(session, &frame));
    TRY(nimbus_frame_find_aov(frame, "alpha", &alpha));
    for (x = 0; x < width; ++x)
        covered += alpha.pixels[(height / 2) * width + x] > 0.3f;
    if (alpha.pixels[(height / 2) * width + width / 2] >= 0.01f || covered < 4) {
        fprintf(stderr, "render_ring: the ring is not where it should be (centre alpha %g, %d covered pixels)\n",
                alpha.pixels[(height / 2) * width + width / 2], covered);
        return 1;
    }
    TRY(nimbus_frame_write_outputs(frame));
    TRY(nimbus_release(frame));
    TRY(nimbus_release(session));
    TRY(nimbus_release(scene));
    printf("render_ring: ok (%d pixels of the middle row covered), wrote %s\n", covered, argv[2]);
    return 0;
}
