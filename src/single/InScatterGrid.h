// InScatterGrid.h: a field of in-scattered radiance that the camera march reads along its rays
// with L1's own samples, for a term computed elsewhere and projected toward the camera (WKB's
// radiance cache, wkb/RadianceGrid.h: orders 2+ or 3+ of the lights).
//
// A regular world-space grid of cubic cells over a box; each cell holds, per layer, RGB S, the
// radiance scattered toward the viewer per unit sigma_s (W / (m^2 sr)), read trilinearly between
// cell centres and clamped at the edge cells. Along a camera ray the term is
//
//     L = int dt T(0, t) sigma_s(x(t)) S(x(t))
//
// which the march sums with L1's quadrature: the same samples t_k, the same transmittance T and
// the same exact int_step e^{-sigma_t u} du, with S read once per group of samples (as many as
// span at most one cell, 2 to 8) at the group's weighted mean position: exact for an S linear
// along the ray (MarchEightRays.cpp). So the term costs the march a trilinear read per group
// instead of a march of its own. The read is the lane-parallel form of wkb::RadianceGrid::fetch
// (cell-centred, clamped at the edge cells).
#pragma once

#include "../core/Vec.h"

namespace nimbus {

// The most layers the eight-ray march reads (each a set of RGB per cell: one light's part, or
// several lights' summed; wkb/RadianceGrid.h "Layers").
constexpr int kMaxInScatterLayers = 4;

struct InScatterGrid {
    const float* rgb = nullptr;  // [cell][layer][rgb], cell (z n[1] + y) n[0] + x
    int layers = 1;              // 1 to kMaxInScatterLayers
    int n[3] = {0, 0, 0};        // cells along each axis
    float3 lo = {0, 0, 0};       // the box's low corner (m)
    float cell = 1.0f;           // the cells' side (m)
};

}  // namespace nimbus
