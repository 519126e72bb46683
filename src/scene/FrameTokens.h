// FrameTokens.h: frame numbers in the paths of a scene, spelled as Houdini, Arnold and Karma
// spell them, so that one scene file renders a shot (docs/sequences.md).
//
//   $F      the frame, unpadded                          smoke.$F.vdb    -> smoke.7.vdb
//   $F<n>   the frame zero-padded to n characters        smoke.$F4.vdb   -> smoke.0007.vdb
//   ###...  a run of n '#': the frame padded to n        smoke.####.vdb  -> smoke.0007.vdb
//
// The width counts the minus sign of a negative frame, as Houdini's padzero does: frame -5 at
// width 4 is "-005". A frame wider than the width is written whole (12345 at width 4: "12345").
// `$F` followed by a letter or '_' is another variable ($FPS, $FSTART, a directory "$Fx"), not a
// frame token, and is left as written. Tokens may appear anywhere, directory names included.
#pragma once

#include "Scene.h"

#include <string>

namespace nimbus {

// The widest padding honoured ($F<n> with a larger n, or a longer run of '#', pads to this):
// far beyond any frame number, small enough that a typo cannot ask for a gigabyte of zeros.
constexpr int kMaxFramePadding = 32;

// `frame` in decimal, zero-padded to `width` characters (the sign included).
std::string padFrame(long long frame, int width);

// The path with every frame token replaced by `frame`; a path without tokens is returned as is.
std::string expandFrameTokens(const std::string& path, long long frame);

// Whether the path holds a frame token.
bool hasFrameTokens(const std::string& path);

// The scene of one frame: render.frame set to `frame`, its animation keys evaluated at the frame
// (evaluateAnimation below), and the tokens of every path replaced:
// each volume's source file and shader, each mesh file, the camera's holdout depth file, the
// output file and preview. Plugin libraries and their parameters are the plugin's own and are
// left as written.
Scene sceneAtFrame(const Scene& scene, int frame);

// Whether any path sceneAtFrame replaces holds a frame token.
bool sceneHasFrameTokens(const Scene& scene);

// Evaluates the scene's animation keys (Animation.h) at render.frame and clears them, leaving
// the frame's static scene. The camera's from, to, up are read at frame + shutter open and, with
// an open shutter, at frame + shutter close as its motion-blur pose. Lights, volume transforms
// and the camera's fov are read at the shutter's centre and, where they move during an open
// shutter, keep their motion within it (Light::shutterMotion, Volume::shutterMotion,
// Camera::fovShutterMotion: the values at open, close and every key between;
// docs/motion-blur.md). Geometry transforms are read at the shutter's centre and not blurred
// within it (one warning where they move during it). Throws InputError if a camera has both
// keys and motion, or if more than NB_CAMERA_FOV_KNOTS - 2 fov keys lie within the shutter.
void evaluateAnimation(Scene& scene);

}  // namespace nimbus
