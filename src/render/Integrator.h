// Integrator.h: the one interface through which the engine (src/engine/) calls every integrator,
// and what each declares about itself for the plan and the film. Models: pbrt-v4's Integrator
// (an image-tile integrator beside whole-image ones) and Mitsuba 3's integrator plugins.
//
// Two ways to be driven:
// - CameraRays (single, wkb): the engine's tile driver generates each pixel sample's camera ray
//   (seed, pixel, sample), calls marchRays for a tile row at a time, sums the samples into the
//   film and keeps progress and cancel. The integrator only marches rays.
// - WholeImage (pathtrace): the integrator fills the film itself (OpenCL launches), reporting
//   progress and obeying cancel through the RenderControl it is given.
// Virtual calls happen once per tile row or per render, never per sample (STYLE rule 5).
#pragma once

#include "../../kernels/shared/rng.h"
#include "../scene/Scene.h"
#include "CameraSample.h"
#include "Film.h"
#include "RenderControl.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace nimbus {

// An integrator's row in the engine's registry: what it produces and what the render context
// must build for it.
struct IntegratorTraits {
    Method method = Method::Single;
    // Radiance AOVs by term, in output order after "beauty" (each 3 channels, half).
    std::vector<std::string> terms;
    // Data AOVs of its own after alpha and depth (each 1 channel, float), e.g. "variance".
    std::vector<std::string> dataAovs;
    // Deep shadow maps for the delta lights (and their bake on the voxels) before it runs.
    bool shadowMaps = false;
};

class Integrator {
public:
    enum class Drive { CameraRays, WholeImage };

    virtual ~Integrator() = default;
    virtual Drive drive() const = 0;

    // Drive::CameraRays. Marches n camera rays o[i] + t d[i] (d unit) with their random streams,
    // writing out[i] (zeroed by the caller) and per-light L1 into perLight[3 lights i + 3 l + c]
    // (zeroed by the caller). tFar[i]: where a holdout stops ray i (docs/geometry.md: nothing at
    // or past it is marched, the ray sees no background), INFINITY where none; tFar null: no
    // holdouts in the scene. time[i]: ray i's shutter fraction in [0, 1] (the camera's time
    // sample), at which moving volumes are read (VolumeSet::sampleAt). Called concurrently from
    // worker threads: const and re-entrant.
    virtual void marchRays(int n, const float3* o, const float3* d, const float* tFar, const float* time, NbRng* rng,
                           CameraSample* out, float* perLight) const
    {
        throw std::logic_error("marchRays called on a whole-image integrator");
    }
    // Drive::CameraRays: whether a tile whose rays can meet no occupied brick may be written as
    // the background without marching (true when the integrator's answer there is the background).
    virtual bool skipsEmptyTiles() const { return true; }

    // Drive::WholeImage. Fills the film's AOVs (sized and added by the engine). Throws Cancelled.
    virtual void renderImage(Film& film, const RenderControl& control)
    {
        throw std::logic_error("renderImage called on a camera-ray integrator");
    }
};

}  // namespace nimbus
