// LightVolumes.h: the light arriving at every point of the volumes, per source, on a sparse grid
// coarser than the density grid, prefiltered into a mip pyramid (Tessendorf sec. 6.3.2, 6.3.5).
//
// Per volume one LightPyramid whose level-0 voxel is `factor` density voxels (the planner's
// choice). Its channels, per voxel y:
//   0                    rho(y), the density averaged over the voxel (8 sub-samples)
//   delta source         rho E(y), E = the source's irradiance on a surface facing it (W/m^2,
//                        RGB) times the transmittance T from the deep shadow map (eq. 27),
//                        averaged over the same sub-samples: L0(y, n') = E(y) delta(n' - N(y))
//   SH source (order J)  rho L^jm(y) = rho int y_jm(n') L0(y, n') dOmega' (eq. 87; W/(m^2 sr)),
//                        for j <= J, RGB innermost, estimated from stratified light samples
//                        with shadow rays at the voxel centre
// Blurred lookups read channel / channel 0: the density-weighted average of the source over
// the blur footprint, i.e. the average over where paths can start (dl = b ds; docs/wkb.md
// "light volumes"). Volumes whose L2+ share is below the tolerance keep channel 0 only, which
// the march still reads for its scattering lengths.
#pragma once

#include "LightPyramid.h"
#include "WkbPlanner.h"

#include <optional>
#include <vector>

namespace nimbus::wkb {

class LightVolumes {
public:
    // Builds the pyramids the setup asks for (TBB-parallel), and the deep shadow maps of delta
    // sources that RenderContext has none for. Writes the measured memory and the stage times
    // into `setup` and `plan`.
    void build(const RenderContext& ctx, const WkbSetup& setup, RenderStats& stats);

    const LightPyramid& pyramid(size_t volume) const { return mPyramids[volume]; }
    size_t memoryBytes() const;

    // A delta source's E(y) (W/m^2, RGB, transmittance included) and its direction of travel
    // N(y) at world point y. rMin floors the distance to point-like sources (metres). Inside the
    // density's bricks the transmittance comes from RenderContext's LightCache where the light
    // has one (the shadow map baked on the voxels, a few loads), else from the shadow map.
    Rgb deltaE(const SourcePlan& source, size_t sourceIndex, float3 y, float rMin) const;
    static float3 deltaDirection(const SourcePlan& source, float3 y);

private:
    void fillLevel0(const RenderContext& ctx, const WkbSetup& setup, size_t volume);

    const RenderContext* mCtx = nullptr;
    std::vector<LightPyramid> mPyramids;
    std::vector<std::optional<DeepShadowMap>> mOwnMaps;  // per source
    std::vector<const DeepShadowMap*> mMaps;             // per source: the map E uses (or null)
};

}  // namespace nimbus::wkb
