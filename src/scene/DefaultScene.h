// DefaultScene.h: the scene nimbus renders when given no scene file (the README's first
// command), and the starting point the docs and tests build on.
#pragma once

#include "Scene.h"

namespace nimbus {

// A procedural cloud of about 2 m radius at the origin, lit by a warm key light from the upper
// left front and a dim cool fill from the right, framed at 640x360 and rendered with the single
// scattering method to out/default.exr (preview out/default.png). Its JSON form is
// tests/scene/data/default.json.
Scene defaultScene();

}  // namespace nimbus
