// LightCache.h: a shadow-mapped light's transmittance baked on each volume's voxel lattice.
//
// The deep shadow map answers T(light -> x) anywhere (Tessendorf eq. 27), but a lookup costs
// four texel searches; the camera march asks at every step. Baking the map at the voxels where
// the density lives (the density grid's own bricks, so one trilinear stencil serves both) makes
// the per-step cost a few loads and one exp. The cache holds the optical depth tau, not T:
// tau is linear where the medium is homogeneous, so interpolating it and then taking e^-tau is
// exact there, whereas interpolating the convex T overestimates it by up to (sigma_t h)^2 / 8
// (measured against the path tracer: +0.4% in L1 at sigma_t h ~ 0.2). Grey media (equal RGB
// extinction everywhere) store one channel.
#pragma once

#include "DeepShadowMap.h"
#include "VolumeSet.h"

#include <cmath>
#include <vector>

namespace nimbus {

class LightCache {
public:
    // stop: the render's (RenderControl.h), polled per brick; a raised one throws Cancelled.
    static LightCache bake(const DeepShadowMap& map, const VolumeSet& volumes, const StopFlag* stop = nullptr);

    // Transmittance from the light at the point whose per-volume stencils are given
    // (VolumeSet::sample fills them): the first volume holding the point answers.
    Rgb transmittance(const BrickGrid::Stencil* stencils) const
    {
        for (size_t v = 0; v < mGrids.size(); ++v) {
            if (stencils[v].brick < 0)
                continue;
            const BrickGrid& g = mGrids[v];
            if (g.channels() == 1) {
                float t = std::exp(-g.interpolate(stencils[v], 0));
                return make_float3(t, t, t);
            }
            return exp(-make_float3(g.interpolate(stencils[v], 0), g.interpolate(stencils[v], 1),
                                    g.interpolate(stencils[v], 2)));
        }
        return splat(1.0f);
    }

    // The optical depth baked on volume v's lattice (the density grid's topology).
    const BrickGrid& grid(size_t v) const { return mGrids[v]; }

    size_t memoryBytes() const;
    double seconds() const { return mSeconds; }

private:
    std::vector<BrickGrid> mGrids;  // per volume, sharing the density grid's topology
    double mSeconds = 0;
};

}  // namespace nimbus
