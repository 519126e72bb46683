// TileDriver.h: how the engine drives a camera-ray integrator (single, wkb): 16 x 16 tiles in
// parallel (TBB), each pixel's samples drawn from (seed, pixel, sample) so that any thread count
// gives the same image; a tile row's camera rays generated first and handed to the integrator
// together (the eight-lane marches take them eight at once), then summed into the film's AOVs.
// Tiles whose rays can meet no occupied brick are written as the background without marching
// (TileCulling.h) where the integrator allows it. Progress after each tile; cancel before each
// tile row and, through RenderContext::stop, inside the marches.
#pragma once

#include "../render/Film.h"
#include "../render/Integrator.h"
#include "../render/RenderContext.h"

namespace nimbus {

// How many camera samples renderTiles took (adaptive sampling, AdaptiveSampling.h): in all, over
// the pixels it marched (not those of tiles that see no volume), and how many of those took the most.
struct TileSampleCounts {
    long long samples = 0, pixels = 0, pixelsAtMost = 0;
    int baseSpp = 0, maxSpp = 0;
};

// Fills the film (sized, AOVs added) with the integrator's camera samples. Throws Cancelled.
void renderTiles(const RenderContext& ctx, const Integrator& integrator, Film& film, const RenderControl& control,
                 TileSampleCounts* counts = nullptr);

}  // namespace nimbus
