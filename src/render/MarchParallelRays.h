// MarchParallelRays.h: an orthographic shadow map's texel rays, eight at once.
//
// The texel rays of an orthographic map are parallel and start on one plane, so they share
// one depth lattice t_k = (k + 1/2) dt (Lattice::FromOrigin): at step k, eight of them sample
// eight points that differ only by their origins. One AVX2 lane per ray: per k, each lane finds
// its brick in the occupancy table and, where the brick is occupied, gathers the trilinear
// density and adds sigma_t rho dt to its optical depth. From the per-k record, each ray's
// vertices are then laid out as DeepShadowMap::marchRay lays them: a vertex where a run of
// samples in occupied bricks starts, one at the end of every step. Same samples and sums as
// the scalar march, up to float rounding and to samples within rounding of a brick face that
// borders an unallocated brick (tested in test_shadowmap.cpp).
#pragma once

#include "DeepShadowMap.h"

#include <vector>

#if defined(__AVX2__) && defined(__FMA__)
#define NIMBUS_EIGHT_TEXEL_MARCH 1
#else
#define NIMBUS_EIGHT_TEXEL_MARCH 0
#endif

namespace nimbus {

#if NIMBUS_EIGHT_TEXEL_MARCH
// marchRay for n <= 8 rays o[i] + t d (world, d unit, every o[i] on one plane normal to d)
// through one volume of grey extinction, at the step dt (metres) of the shared lattice: *raw[i]
// receives ray i's vertices. False, with nothing written, where the pools are too large for
// 32-bit gathers or a march too long for float sample indices: march those one by one.
// A raised `stop` ends the march early (true, the vertices to be discarded).
bool marchEightParallelRays(const VolumeData& vol, const float3* o, int n, float3 d, float dt,
                            std::vector<DeepShadowMap::Vertex>* const* raw, const StopFlag* stop = nullptr);
#endif

}  // namespace nimbus
