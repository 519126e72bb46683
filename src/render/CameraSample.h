// CameraSample.h: what one camera ray gathers, the unit the engine's tile driver sums into
// pixels and the camera-ray integrators (single, wkb) fill.
#pragma once

#include "../core/Vec.h"

namespace nimbus {

// Radiance in W/(m^2 sr); an integrator's per-light L1 goes to a separate array, 3 floats per light.
struct CameraSample {
    Rgb L0 = splat(0.0f);      // emission and background seen through the medium (Tessendorf eq. 26)
    Rgb L1 = splat(0.0f);      // single scattering (eqs. 31-33)
    Rgb L2plus = splat(0.0f);  // multiple scattering (wkb only)
    Rgb transmittance = splat(1.0f);
    float depth = 0.0f;    // opacity-weighted mean distance along the ray, metres; 0 if empty
    float opacity = 0.0f;  // the ray's opacity summed step by step: the depth's weight in a pixel
};

}  // namespace nimbus
