// LightPyramid.h: a sparse 3D mip pyramid of multi-channel light volumes (Tessendorf sec. 6.3.5,
// "precompute the blurred data at a variety of blur levels ... interpolate across the set").
//
// Level 0 holds, per light-grid voxel, channel 0 = the density rho and channels 1.. = rho times
// each light's source (docs/wkb.md "light volumes"); the caller fills it. Level k is level k-1
// filtered by the binomial [1 4 6 4 1]/16 in each axis and decimated by two, the samples
// co-located (level-k voxel i sits on level-(k-1) voxel 2i). Each pass adds variance 1 in the
// units of the finer level, so level k has blurred level 0 by a Gaussian-like kernel of variance
//     sigma_k^2 = (4^k - 1) / 3      (level-0 voxels^2, per axis; exact second moment)
// and a lookup with blur sigma reads the fractional level lambda = log4(3 sigma^2 + 1),
// trilinear within each of the two nearest levels and linear across them.
//
// Sparse: every level is a BrickGrid (8^3 voxels per brick plus the apron) holding the parents of
// the finer level's bricks, so memory follows the active region (about 8/7 of level 0 in all).
// Values beyond the bricks read as zero, and the filter's tails past them are dropped; because
// channel 0 carries the same weights, the ratio channel / channel 0 (a normalised convolution)
// is a weighted average of the source either way.
#pragma once

#include "../render/RenderControl.h"
#include "../volume/BrickGrid.h"

#include <vector>

namespace nimbus::wkb {

class LightPyramid {
public:
    // Allocates level 0 over the given bricks (level-0 brick coordinates, duplicates allowed).
    void allocateLevel0(const std::vector<Int3>& bricks, int channels);
    int channels() const { return mChannels; }
    size_t level0BrickCount() const { return mLevel0.size(); }
    Int3 level0Brick(size_t i) const { return mLevel0[i].coord; }
    // kStored^3 * channels floats, x fastest, channel innermost: level-0 voxel
    // (8 bx + x, 8 by + y, 8 bz + z) for x, y, z in [0, 8] (8 is the apron).
    float* level0Values(size_t i) { return mLevel0[i].values; }

    // Builds levels 1.. (TBB-parallel over bricks) until sigma_k exceeds `maxSigma` level-0
    // voxels or `maxLevels` levels exist. Then updates every level's majorants. stop: the
    // render's (RenderControl.h), polled per brick; a raised one throws Cancelled.
    void buildLevels(float maxSigma, int maxLevels, const StopFlag* stop = nullptr);

    int levels() const { return int(mLevels.size()); }
    const BrickGrid& level(int k) const { return mLevels[k]; }
    size_t memoryBytes() const;

    // The bricks of the next coarser level that the filter reaches from `fine` (sorted, unique),
    // and the memory of a level over `bricks` (the rule buildLevels follows; the planner uses both).
    static std::vector<Int3> coarserBricks(const std::vector<Int3>& fine);
    static size_t levelBytes(const std::vector<Int3>& bricks, int channels);
    static constexpr int kMaxLevels = 16;

    // Fractional level for a Gaussian blur of standard deviation sigma (level-0 voxels).
    static float levelForSigma(float sigma);
    // Standard deviation of level k's blur, level-0 voxels.
    static float sigmaOfLevel(float k);

    // Adds weight * (trilinear value at level-0 index position p0, blurred by sigma level-0
    // voxels) of channels [c0, c0 + n) to out[0..n).
    void fetch(float3 p0, float sigma, int c0, int n, float weight, float* out) const;
    // The same at one level, no blending (tests).
    void fetchLevel(int k, float3 p0, int c0, int n, float weight, float* out) const;

private:
    struct Level0Brick {
        Int3 coord;
        float* values;
    };
    void buildLevel(int k, const StopFlag* stop);

    int mChannels = 0;
    std::vector<BrickGrid> mLevels;
    std::vector<Level0Brick> mLevel0;
};

}  // namespace nimbus::wkb
