/* broken_plugin.c: a volume plugin that forgot nimbus_volume_sample, for the "missing symbol"
 * error test. Everything else is there, so the message must name that one symbol. */
#include "nimbus_volume_plugin.h"

#include <stdlib.h>

NIMBUS_VOLUME_PLUGIN_EXPORT int nimbus_volume_plugin_version(void)
{
    return NIMBUS_VOLUME_PLUGIN_VERSION;
}

NIMBUS_VOLUME_PLUGIN_EXPORT void* nimbus_volume_init(const NimbusVolumeParam* params, size_t count, char* error,
                                                     size_t errorSize)
{
    (void)params, (void)count, (void)error, (void)errorSize;
    return malloc(1);
}

NIMBUS_VOLUME_PLUGIN_EXPORT int nimbus_volume_bounds(void* state, NimbusVolumeBounds* b, char* error, size_t errorSize)
{
    int a;
    (void)state, (void)error, (void)errorSize;
    for (a = 0; a < 3; ++a)
        b->min[a] = -1, b->max[a] = 1;
    b->voxel_size = 0.1;
    return 0;
}

NIMBUS_VOLUME_PLUGIN_EXPORT void nimbus_volume_cleanup(void* state)
{
    free(state);
}
