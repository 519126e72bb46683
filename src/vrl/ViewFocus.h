// ViewFocus.h: where the orders-3+ cache's light paths are worth sending (docs/wkb.md "Orders 3
// and up, traced", "Paths aimed at the view").
//
// The cache (Orders3Grid.h) is read only along camera rays, within a few mean free paths of what
// the camera sees. Where the camera sees part of a large medium (a close-up of a big cloud, a slab
// or a half-space seen through a narrow lens) the light pass spreads its paths over the whole
// medium, and the cells the camera reads get a small share of them: a lit half-space seen 2.5% of
// its face came out 17% bright and 35-55% dark in its orders 3+ at the default path count (within
// 2% with 64 times the paths: noise, not bias).
//
// The focus is a sphere around what the camera sees, widened by the distance light travels
// sideways before it reaches the camera (a few diffusion lengths): the light pass then draws a
// share of its paths toward it (LightPass::setFocus), with the mixture's pdf in their weights, so
// the cache stays unbiased and only its noise moves.
//
// What the camera sees: rays over the image (kFocusRays along the longer side), marched through
// the volumes; every point with sigma_s > 0 and T_cam >= kFocusMinTransmittance counts. The width:
// kFocusDiffusionLengths times the largest diffusion length 1 / (sigma_t sqrt(3 (1 - omega)(1 - g
// omega))) of those points (sigma_t the largest sampled, the medium under a face rather than its
// ramp; omega and g weighted by sigma_s T_cam), and at least two cells of the cache.
#pragma once

#include "../render/RenderContext.h"

namespace nimbus::vrl {

struct EmissionFocus {
    bool active = false;
    float3 centre = make_float3(0, 0, 0);
    float radius = 0.0f;  // m
};

constexpr int kFocusRays = 48;
constexpr float kFocusMinTransmittance = 1e-3f;
constexpr float kFocusDiffusionLengths = 3.0f;
// The focus is used only where its sphere is at most this fraction of the volumes' bounding
// sphere's radius (a smaller gain is not worth the weights' spread).
constexpr float kFocusMaxRadiusFraction = 0.7f;

// The focus for ctx's camera (at the shutter's centre), inactive where the camera sees no medium,
// sees most of it, or the scene has no camera. cellSize: the cache's cells (m); boundsRadius: the
// radius of the sphere the light pass emits over (LightPass).
EmissionFocus findViewFocus(const RenderContext& ctx, float cellSize, float boundsRadius);

}  // namespace nimbus::vrl
