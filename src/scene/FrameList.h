// FrameList.h: the frames a sequence render visits, from the CLI's `--frames` spelling
// (docs/sequences.md): comma-separated items, each a frame N, a range A-B (both included) or a
// stepped range A-BxS (A, A+S, ... up to B). Frames may be negative ("-5--1"). Kept in the
// order given.
#pragma once

#include <string>
#include <vector>

namespace nimbus {

// The most frames one list may name: beyond any shot, and a typo ("1-2000000000") is refused
// rather than allocated.
constexpr size_t kMaxFrames = 1000000;

// Throws InputError "bad frame list '<spec>': <what>" for anything else: an empty item, a
// range that runs backwards, a step under 1, a frame outside int, a frame named twice, more
// than kMaxFrames frames.
std::vector<int> parseFrameList(const std::string& spec);

}  // namespace nimbus
