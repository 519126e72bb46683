// KernelScene.h: converts the scene's camera and lights to the plain structs of
// kernels/shared/ that the host integrators and the OpenCL path tracer both read.
#pragma once

#include "../../kernels/shared/camera.h"
#include "../../kernels/shared/filter.h"
#include "../../kernels/shared/light.h"
#include "../../kernels/shared/motion.h"
#include "Scene.h"

#include <vector>

namespace nimbus {

NbCamera makeNbCamera(const Camera& camera);
// NB_FILTER_* of the scene's pixel filter (kernels/shared/filter.h).
int nbFilterType(PixelFilter filter);
NbLight makeNbLight(const Light& light, int index);
std::vector<NbLight> makeNbLights(const Scene& scene);
// The light's motion within the shutter (Light::shutterMotion) as motion.h's knots, times in
// seconds after the frame's (frames / fps); empty where the light holds still.
std::vector<float> lightMotionKnots(const Light& light, float fps);

}  // namespace nimbus
