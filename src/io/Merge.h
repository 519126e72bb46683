// Merge.h: `nimbus merge OUT.exr PARTS...` (docs/farm.md, issue 16 item 4): the parts of one
// frame, rendered as tiles (`--tile I/N`) and/or path-tracer sample splits (`--samples A-B`, or
// another render.seed), put back together into the frame.
//
// - Tiles are pasted: every pixel of a tile is the whole frame's pixel bit for bit (each pixel
//   draws its own samples from (seed, pixel, sample)), so N tiles merged are the frame rendered
//   in one piece, bit for bit, for every method.
// - Sample splits of one tile pool their running estimates (PathtraceState.h): each mean weighted
//   by its part's sample count, Welford's M2 with the spread of the parts' means (the exact pooled
//   variance), then resolved into the output AOVs as the path tracer resolves its own.
//
// What is checked from the parts' headers before anything is written, each failure one line
// naming the part (InputError): every part is a finished nimbus frame (nimbus:complete 1); one
// method, frame and scene (the scene JSON compared without `output`, and for the path tracer
// without its stopping rules and seed, which splits may differ in); the same image size, AOVs
// and tile count; every tile 1..N present; within a tile, no two parts sharing samples (the same
// seed and overlapping sample ranges, or any second part of a method that has no sample splits);
// every tile with the same samples. The output is written atomically (ExrWriter.h).
#pragma once

#include <string>
#include <vector>

namespace nimbus {

struct MergeSummary {
    int parts = 0;
    int tiles = 0;            // N of --tile I/N (1: the parts are not tiles)
    int splitsPerTile = 0;    // parts per tile (1: tiles only)
    long long spp = 0;        // samples per pixel of the merged frame
};

MergeSummary mergeParts(const std::string& output, const std::vector<std::string>& parts);

}  // namespace nimbus
