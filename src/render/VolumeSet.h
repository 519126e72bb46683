// VolumeSet.h: the scene's volumes as one participating medium, in world space.
//
// It answers the two questions every marcher asks: "where along this ray is there anything?"
// (spans, found by a 3D DDA over each grid's brick table, which is the empty-space skipping of
// DESIGN "L1") and "what are the coefficients here?" (sum over overlapping volumes).
#pragma once

#include "../../kernels/shared/motion.h"
#include "../volume/VolumeData.h"
#include "RenderControl.h"

#include <memory>
#include <vector>

namespace nimbus {

// A stretch [t0, t1] of a ray that may hold non-zero density, with the march step there.
struct Span {
    float t0, t1;
    float step;  // world-space step for this span, metres
};

// Coefficients at a point, summed over volumes (Tessendorf sec. 2: b, a, c = a + b).
struct MediumSample {
    Rgb sigma_t = splat(0.0f);   // 1/m
    Rgb sigma_s = splat(0.0f);   // 1/m
    Rgb emission = splat(0.0f);  // W/(m^3 sr)
};

class VolumeSet;
// VolumeSet::setShutter from the scene: camera.shutter (frames after the frame) / render.fps;
// and each volume's transform motion within the shutter (Volume::shutterMotion) as
// VolumeSet::setTransformMotion.
void setShutterOf(VolumeSet& volumes, const Scene& scene);

// A volume's transform motion within the shutter in kernels/shared/motion.h's layout (indexFromUser,
// then the knots [seconds, T, R, S]): empty where the volume holds still. `data` was built with
// the volume's `transform` (the shutter centre's), so indexFromUser = data.indexFromWorld * transform.
std::vector<float> transformMotionBlock(const Volume& volume, const VolumeData& data, float fps);

class VolumeSet {
public:
    VolumeSet() = default;
    VolumeSet(std::vector<std::shared_ptr<VolumeData>> volumes, float stepFraction);

    bool empty() const { return mVolumes.empty(); }
    const std::vector<std::shared_ptr<VolumeData>>& volumes() const { return mVolumes; }
    const Bbox& worldBounds() const { return mBounds; }
    bool hasEmission() const { return mHasEmission; }
    float minVoxelSize() const { return mMinVoxel; }

    // Spans along o + t d, t in [tmin, tmax], sorted and merged; `stepScale` multiplies the
    // per-volume step (voxel size times the step fraction). d need not be unit length, but the
    // steps are in the units of t, so callers pass unit d.
    void spans(float3 o, float3 d, float tmin, float tmax, float stepFraction, std::vector<Span>& out) const;

    // Coefficients at world point p. `phaseOut`, if given, receives per-volume sigma_s weights
    // (index-aligned with volumes()) for mixing phase functions.
    MediumSample sample(float3 p, float* phaseWeights = nullptr) const;
    // The same, also returning each volume's density stencil at p (brick -1 where the volume
    // does not reach p), through which grids sharing its topology are read.
    MediumSample sample(float3 p, float* phaseWeights, BrickGrid::Stencil* stencils) const;

    // ---- motion blur (docs/motion-blur.md): velocity and transform motion ----
    // The shutter [open, close] in seconds after the frame's time (camera.shutter / render.fps).
    // The set then moves where some volume has a velocity grid and the shutter is open: at
    // shutter time s the medium at world point p is each volume's at its index point
    // q - v(q) s, q = p in that volume's index space (rho(x - v (t - t0)), the convention of
    // Arnold, Karma, Cycles and RenderMan; exact for a uniform v, first order otherwise).
    void setShutter(float openSeconds, float closeSeconds);
    // Transform motion (motion.h): volume i's transform moves within the shutter by `block`
    // (transformMotionBlock); at shutter time s its index point of world p is
    // indexFromWorld(s) p, the transform interpolated as the animation keys are. Empty: still.
    void setTransformMotion(size_t i, std::vector<float> block);
    const std::vector<float>& transformMotion(size_t i) const { return mMotion[i]; }
    int transformKnots(size_t i) const
    {
        return mMotion[i].empty() ? 0 : int(mMotion[i].size() / NB_MOTION_KNOT) - 1;
    }
    // Volume i's world-to-index matrix (3x4 row-major, float) at shutter time `seconds`.
    void indexFromWorldAt(size_t i, float seconds, float* m) const;
    // The position of volume i in the list the set was made from (buildVolumes: the scene's).
    size_t sceneIndex(size_t i) const { return mSceneIndex[i]; }
    bool moving() const { return mMoving; }
    // Seconds after the frame's time at shutter fraction u in [0, 1] (the camera's time sample).
    float shutterSeconds(float u) const { return mShutterOpen + (mShutterClose - mShutterOpen) * u; }
    // The largest displacement of volume i over the shutter, in its index voxels.
    float maxDisplacement(size_t i) const { return i < mMaxDisplacement.size() ? mMaxDisplacement[i] : 0.0f; }
    // What the moving set can reach over the whole shutter: each moving volume's occupied box
    // grown by its largest displacement (and a voxel for the trilinear velocity read), swept by
    // its transform motion.
    const Bbox& movingBounds() const { return mMoving ? mMovingBounds : mBounds; }
    Bbox movingIndexBounds(size_t i) const;
    // spans and sample at shutter time `seconds` (as above when the set does not move). A
    // volume moved by velocity spans its whole grown box: which bricks hold density depends on
    // the time; one moved by its transform alone spans its occupied bricks at that time.
    void spansAt(float seconds, float3 o, float3 d, float tmin, float tmax, float stepFraction,
                 std::vector<Span>& out) const;
    MediumSample sampleAt(float seconds, float3 p, float* phaseWeights = nullptr) const;
    // The same with the stencils at each volume's moved index point, and `lightPoint`: the world
    // point whose light this sample sees, p moved back with the volume that scatters most there
    // (the light maps, baked transmittance, sky grids and light volumes are the frame's, so
    // they are read where that volume's matter was at the frame's time: for velocity, the
    // grid's own time; for a moving transform, the shutter centre's placement, which they were
    // built with).
    MediumSample sampleAt(float seconds, float3 p, float* phaseWeights, BrickGrid::Stencil* stencils,
                          float3* lightPoint) const;
    // lightPoint alone.
    float3 lightPointAt(float seconds, float3 p) const;

    // Optical depth (RGB) along the segment o + t d, t in [t0, t1], by midpoint marching at
    // `stepFraction` voxels over the non-empty spans. Used by shadow maps and shadow rays.
    // A raised `stop` (RenderControl.h) ends the march early, its value then to be discarded:
    // a ray is 1 / stepFraction samples per voxel, and the caller's own poll may be far away.
    Rgb opticalDepth(float3 o, float3 d, float t0, float t1, float stepFraction, const StopFlag* stop = nullptr) const;

private:
    // Per-volume constants of the hot loop: the index-from-world matrix in float (the double
    // Transform is exact for placement; a step needs 1e-7 relative, not 1e-16) and the
    // coefficients at density 1.
    struct Hot {
        float m[12];
        Rgb sigmaS, sigmaT;
        float emissionScale;
        float3 index(float3 p) const
        {
            return make_float3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                               m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
        }
    };
    std::vector<Hot> mHot;
    // Velocity motion blur: the shutter in seconds, per volume its largest displacement (index
    // voxels), and the union of the grown boxes in world space.
    bool mMoving = false;
    float mShutterOpen = 0.0f, mShutterClose = 0.0f;
    std::vector<float> mMaxDisplacement;
    Bbox mMovingBounds;
    std::vector<std::vector<float>> mMotion;  // per volume: its transform motion block, or empty
    std::vector<size_t> mSceneIndex;
    unsigned long long mMotionId = 0;  // new for every change of the motion: indexAt's cache key
    void updateMotion();  // mMoving and mMovingBounds from the displacements and mMotion
    // Volume i's index point of world p at shutter time s (before any velocity).
    float3 indexAt(size_t i, float3 p, float seconds) const;
    // Volume i's index point at shutter time s: q - v(q) s.
    float3 movedIndex(size_t i, float3 q, float seconds) const;
    std::vector<std::shared_ptr<VolumeData>> mVolumes;
    Bbox mBounds;
    bool mHasEmission = false;
    float mMinVoxel = 1.0f;
};

}  // namespace nimbus
