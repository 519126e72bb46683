// ShadowCasters.h: the shadow casters (docs/geometry.md) as vrl's walks meet them, one query each
// for the light pass, the camera paths, the gathers and the radiance cache.
#pragma once

#include "../../kernels/shared/geometry.h"
#include "../../kernels/shared/majorant.h"  // NB_INF
#include "../pathtracer/PathtraceScene.h"

namespace nimbus::vrl {

// Where o + t d (d unit) first meets a shadow caster; infinity where it meets none.
inline float casterDistance(const PathtraceScene& ps, float3 o, float3 d)
{
    return ps.shadowCasters ? nbGeomTrace(ps.geometry.nodes.data(), ps.geometry.prims.data(), ps.geometry.scene, o, d,
                                          0.0f, NB_INF, NB_GEOM_SHADOWS, 0)
                            : NB_INF;
}

// Whether a shadow caster lies on o + t d, t in [0, dist].
inline bool casterBetween(const PathtraceScene& ps, float3 o, float3 d, float dist)
{
    return ps.shadowCasters && nbGeomTrace(ps.geometry.nodes.data(), ps.geometry.prims.data(), ps.geometry.scene, o, d,
                                           0.0f, dist, NB_GEOM_SHADOWS, 1) < NB_INF;
}

}  // namespace nimbus::vrl
