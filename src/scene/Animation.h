// Animation.h: time-sampled scene values (issue 16, item 2; docs/scene-format.md "Animation").
//
// A key list `[{"frame": f, "value": v}, ...]` in place of a camera's `from`, `to`, `up`, `fov`,
// a light's `position`, `direction`, `center`, `normal`, `up`, or a volume's or geometry's
// `transform`. Between two keys the value is interpolated linearly in the frame number
// (positions, directions, fov); transforms are split into translation, rotation and scale
// (T R S, no shear), the translations and scales interpolated linearly and the rotations by
// quaternion slerp (the shorter arc). Before the first key and after the last the value holds.
// Frames are real numbers: a shutter [open, close] in frames reads the keys at frame + open and
// frame + close, so the same keys drive a sequence and the motion blur within a frame.
#pragma once

#include "../core/Transform.h"
#include "../core/Vec.h"

#include <stdexcept>
#include <vector>

namespace nimbus {

// The keys of one animated value, sorted by frame, frames distinct. Empty: not animated.
template <class T>
struct Keys {
    std::vector<double> frames;
    std::vector<T> values;
    bool animated() const { return !frames.empty(); }
};

// The value at `frame` (keys non-empty).
float3 evaluateKeys(const Keys<float3>& keys, double frame);
float evaluateKeys(const Keys<float>& keys, double frame);
Transform evaluateKeys(const Keys<Transform>& keys, double frame);

// A transform split as T R S: translation, rotation quaternion (w, x, y, z), per-axis scale.
struct TrsParts {
    double translate[3];
    double rotation[4];
    double scale[3];
};

// Throws std::invalid_argument where the matrix is not an affine T R S (shear, projective row,
// a zero scale).
TrsParts splitTrs(const Transform& t);
Transform composeTrs(const TrsParts& p);

}  // namespace nimbus
