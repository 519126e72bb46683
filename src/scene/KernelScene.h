// KernelScene.h: converts the scene's camera and lights to the plain structs of
// kernels/shared/ that the host integrators and the OpenCL path tracer both read.
#pragma once

#include "../../kernels/shared/camera.h"
#include "../../kernels/shared/light.h"
#include "Scene.h"

#include <vector>

namespace nimbus {

NbCamera makeNbCamera(const Camera& camera);
NbLight makeNbLight(const Light& light, int index);
std::vector<NbLight> makeNbLights(const Scene& scene);

}  // namespace nimbus
