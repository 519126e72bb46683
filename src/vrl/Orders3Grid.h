// Orders3Grid.h: fills WKB's traced radiance cache for orders 3 and up (wkb/RadianceGrid.h;
// render.wkb_orders3 = "traced", docs/wkb.md "Orders 3 and up, traced") from the VRL light pass
// (VrlLightPass.h): the same light paths (lights chosen by power, delta tracking on the path
// tracer's brick majorants, its Russian roulette), each segment that leaves a path's second or
// later scattering vertex deposited along the cells it crosses with its expected track length,
// weighted by the phase function toward the camera.
#pragma once

#include "../render/RenderContext.h"
#include "../wkb/RadianceGrid.h"

#include <memory>
#include <vector>

namespace nimbus::vrl {

struct Orders3Options {
    // Light paths in all (render.wkb_orders3_paths); 0: as many as the cache's measured noise asks
    // (traceOrders3), at most maxPaths.
    long long paths = 0;
    long long maxPaths = 1 << 24;
    int maxCells = 64;     // cells along the box's longest side (render.wkb_orders3_grid)
    uint32_t seed = 0;     // render.seed
    // The first segment order deposited: 2 (a segment leaving the second scattering vertex) gives
    // orders 3 and up at the camera. Tests set 1 or 3 to show that a wrong order is caught.
    int firstOrder = 2;
    // Skin cells (SkinCells.h): where the camera sees a cell many diffusion lengths deep, the
    // camera-weighted mean instead of the volume mean. Tests turn it off to show that the volume
    // mean fails on a lit face.
    bool skinCells = true;
    // Paths aimed at what the camera sees (ViewFocus.h), where it sees a small part of the medium.
    // Tests turn it off to show that the cache's mean does not move.
    bool focus = true;
    // Deposits aimed at the camera (Orders3Grid.cpp, aimDeposit): each deposited segment's
    // direction drawn from the mixture of the vertex's phase function and the same lobe turned
    // toward the camera, instead of the light path's own. Tests turn it off to show that the
    // cache's mean does not move.
    bool aimDeposits = true;
    // Per RenderContext::lights index: nonzero where that light's AOV is written. Where the scene's
    // lights that reach a volume are several and some of their AOVs are written, the cache keeps
    // one layer per such light (and one for the others, if any): RadianceGrid "Layers". Empty or
    // all zero: one layer, all lights summed.
    std::vector<char> perLightAovs;
    // The point the cache is projected toward (RadianceGrid.h): where unset, the camera's eye at
    // the shutter's centre, which the camera rays that read it start from. Tests move it to show
    // that a cache projected toward another point fails.
    bool hasViewer = false;
    float3 viewer = make_float3(0, 0, 0);
};

// The most light paths the cache of `scene` may take: render.wkb_orders3_paths, or where it is 0
// (the default: the count adapts to the cache's noise, traceOrders3)
//
//     P_max = 65536 sqrt(pixels x spp),   clamped to [65536, 2^24]
//
// (spp: the scene's, or the march's default 4: 8.4 M at 64x64, 2^24 from 256x256 up; docs/wkb.md
// "How many light paths"): a bound on the pass's time for the image's size that lets every
// calibration scene's count reach the cache's noise target.
long long orders3PathCap(const Scene& scene);

// The cache's cells along the volumes' longest side: render.wkb_orders3_grid, or where it is 0 (the
// default) 48, more where a cell would be too coarse for the radiance under a dense medium's face.
int orders3GridCells(const RenderContext& ctx);

// What traceOrders3 decided, for `nimbus render --explain` (RenderStats::orders3).
struct Orders3Report {
    size_t cells = 0;      // the cache's cells
    size_t skinCells = 0;  // of those, skin cells (SkinCells.h)
    bool aimedAtView = false;  // the paths aimed at a focus around the seen medium (ViewFocus.h)
    float focusRadius = 0.0f;  // its radius (m)
    long long paths = 0;       // the light paths traced
    bool adaptive = false;     // their count adapted to the measured noise (Orders3Options::paths 0)
    bool blurred = true;       // the cache blurred (the adaptive count leaves it sharp where it can)
    // Adaptive: the relMSE the cache added to the image as last measured, at noisePaths paths
    // (-1 and 0 where nothing was measured: the first round already reached the cap).
    double noiseMeasured = -1.0;
    double noiseStdErr = 0.0;  // its standard error, from the spread of the pilot rays' terms
    long long noisePaths = 0;
};

// The grid of ctx's scene, or null where no light reaches a volume. Where a single light reaches the
// volumes its one layer is that light's (layerLight 0 = its index). Deterministic for a seed on
// any thread count: the segments are split into a fixed number of ranges (8 over the layer count, at least 2), each summed in order into
// its own grid, and the partial grids are added in a fixed order.
//
// With options.paths 0 the count adapts to the scene: a first round of 65536 light paths, then
// the count where the relMSE the cache's noise adds to the image, falling as one over the paths,
// is under a target fitted on the calibration suite (and at least the error x time optimum). The
// noise is measured on pilot camera rays (a lattice of pixels) reading two caches, each from half of
// every batch's segments; at most options.maxPaths paths and three rounds. The cache is left
// unblurred where, at the first round, its sharp noise asks for no more paths than its blurred
// noise (Orders3Report::blurred).
std::shared_ptr<const wkb::RadianceGrid> traceOrders3(const RenderContext& ctx, const Orders3Options& options,
                                                      Orders3Report* report = nullptr);

// The most memory traceOrders3 holds in grids while it fills ctx's cache (bytes): the cache and its
// partial grids, for the layer count (at most one per light of ctx) that needs the most. The
// batch's light-path segments (8192 paths) are not counted: their number follows the medium.
size_t orders3FillBytes(const RenderContext& ctx, const Orders3Options& options);

}  // namespace nimbus::vrl
