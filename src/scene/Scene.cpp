#include "Scene.h"

namespace nimbus {

const char* lightTypeName(LightType t)
{
    switch (t) {
    case LightType::Distant: return "distant";
    case LightType::Point: return "point";
    case LightType::Spot: return "spot";
    case LightType::Rect: return "rect";
    case LightType::Sphere: return "sphere";
    case LightType::Environment: return "environment";
    }
    return "?";
}

const char* geometryTypeName(GeometryType t)
{
    switch (t) {
    case GeometryType::Mesh: return "mesh";
    case GeometryType::Sphere: return "sphere";
    case GeometryType::Plane: return "plane";
    }
    return "?";
}

const char* methodName(Method m)
{
    switch (m) {
    case Method::Single: return "single";
    case Method::Wkb: return "wkb";
    case Method::Pathtrace: return "pathtrace";
    case Method::Vrl: return "vrl";
    }
    return "?";
}

const char* pixelFilterName(PixelFilter f)
{
    switch (f) {
    case PixelFilter::Box: return "box";
    case PixelFilter::Gaussian: return "gaussian";
    case PixelFilter::BlackmanHarris: return "blackman_harris";
    }
    return "gaussian";
}

const char* wkbKernelName(WkbKernel k)
{
    return k == WkbKernel::Exact ? "exact" : "gaussian";
}

const char* wkbSourceName(WkbSource s)
{
    return s == WkbSource::RandomWalk ? "random_walk" : "straight";
}

const char* vrlSamplingName(VrlSampling s)
{
    switch (s) {
    case VrlSampling::Auto: return "auto";
    case VrlSampling::Simple: return "simple";
    case VrlSampling::Advanced: return "advanced";
    }
    return "auto";
}

const char* wkbOrder2Name(WkbOrder2 o)
{
    switch (o) {
    case WkbOrder2::Traced: return "traced";
    case WkbOrder2::Kernel: return "kernel";
    case WkbOrder2::Cache: return "cache";
    case WkbOrder2::Auto: return "auto";
    }
    return "traced";
}

const char* wkbOrders3Name(WkbOrders3 o)
{
    return o == WkbOrders3::Traced ? "traced" : "kernel";
}

}  // namespace nimbus
