#include "KernelScene.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

namespace {

void store(float* dst, float3 v, float w = 0.0f)
{
    dst[0] = v.x, dst[1] = v.y, dst[2] = v.z, dst[3] = w;
}

float cosDegrees(double deg)
{
    return float(std::cos(deg * M_PI / 180.0));
}

void frame(float3 from, float3 to, float3 up, float* origin, float* forward, float* right)
{
    float3 f = normalize(to - from);
    float3 r = normalize(cross(f, up));
    store(origin, from);
    store(forward, f);
    store(right, r);
}

}  // namespace

static_assert(sizeof(NbCamera) == 176, "NbCamera layout is shared with OpenCL");
static_assert(sizeof(NbLight) == 112, "NbLight layout is shared with OpenCL");

int nbFilterType(PixelFilter filter)
{
    switch (filter) {
    case PixelFilter::Box: return NB_FILTER_BOX;
    case PixelFilter::Gaussian: return NB_FILTER_GAUSSIAN;
    case PixelFilter::BlackmanHarris: return NB_FILTER_BLACKMAN_HARRIS;
    }
    return NB_FILTER_GAUSSIAN;
}

NbCamera makeNbCamera(const Camera& c)
{
    NbCamera k{};
    frame(c.from, c.to, c.up, k.originOpen, k.forwardOpen, k.rightOpen);
    if (c.hasMotion)
        frame(c.fromClose, c.toClose, c.upClose, k.originClose, k.forwardClose, k.rightClose);
    else
        frame(c.from, c.to, c.up, k.originClose, k.forwardClose, k.rightClose);
    k.tanHalfFov = float(std::tan(c.fov * M_PI / 360.0));
    k.aspect = float(c.width) / float(c.height);
    k.hasMotion = c.hasMotion ? 1.0f : 0.0f;
    // A zoom within the shutter: the knots' times as fractions of the shutter (evaluateAnimation
    // keeps at most NB_CAMERA_FOV_KNOTS, open first and close last).
    const Keys<float>& fov = c.fovShutterMotion;
    const double shutter = double(c.shutterClose) - double(c.shutterOpen);
    if (fov.frames.size() >= 2 && fov.frames.size() <= size_t(NB_CAMERA_FOV_KNOTS) && shutter > 0.0) {
        k.fovKnots = float(fov.frames.size());
        for (size_t j = 0; j < fov.frames.size(); ++j) {
            k.fovTime[j] = float(std::clamp((fov.frames[j] - double(c.shutterOpen)) / shutter, 0.0, 1.0));
            k.fovHalf[j] = float(double(fov.values[j]) * M_PI / 360.0);
        }
    }
    return k;
}

NbLight makeNbLight(const Light& l, int index)
{
    NbLight k{};
    k.index = index;
    switch (l.type) {
    case LightType::Distant:
        k.type = NB_LIGHT_DISTANT;
        store(k.direction, normalize(l.direction));
        store(k.color, l.irradiance);
        k.p0 = l.angle > 0 ? cosDegrees(0.5 * l.angle) : 1.0f;
        break;
    case LightType::Point:
        k.type = NB_LIGHT_POINT;
        store(k.position, l.position);
        store(k.color, l.intensity);
        break;
    case LightType::Spot: {
        k.type = NB_LIGHT_SPOT;
        store(k.position, l.position);
        store(k.direction, normalize(l.direction));
        store(k.color, l.intensity);
        double outer = 0.5 * l.coneAngle;
        double inner = std::max(0.0, outer - double(l.coneSoftness));
        k.p0 = cosDegrees(outer);
        k.p1 = cosDegrees(inner);
        break;
    }
    case LightType::Rect: {
        k.type = NB_LIGHT_RECT;
        float3 n = normalize(l.normal);
        float3 v = l.up - n * dot(l.up, n);
        v = normalize(v);
        float3 u = cross(v, n);
        store(k.position, l.center);
        store(k.direction, n);
        store(k.axisU, u * (0.5f * l.size[0]));
        store(k.axisV, v * (0.5f * l.size[1]));
        store(k.color, l.radiance);
        break;
    }
    case LightType::Sphere:
        k.type = NB_LIGHT_SPHERE;
        store(k.position, l.position);
        store(k.color, l.radiance);
        k.p0 = l.radius;
        break;
    case LightType::Environment:
        k.type = NB_LIGHT_ENVIRONMENT;
        store(k.color, l.radiance * l.mapIntensity);  // times map(w) where there is a map
        break;
    }
    return k;
}

std::vector<float> lightMotionKnots(const Light& l, float fps)
{
    const auto& k = l.shutterMotion;
    if (k.frames.size() < 2)
        return {};
    std::vector<float> out(NB_MOTION_KNOT * k.frames.size(), 0.0f);
    const bool rect = l.type == LightType::Rect;
    for (size_t j = 0; j < k.frames.size(); ++j) {
        float* knot = out.data() + NB_MOTION_KNOT * j;
        const Light::Pose& p = k.values[j];
        const float3 v[3] = {rect ? p.center : p.position, rect ? p.normal : p.direction, p.up};
        knot[0] = float(k.frames[j] / double(fps));
        for (int a = 0; a < 3; ++a)
            knot[1 + 3 * a] = v[a].x, knot[2 + 3 * a] = v[a].y, knot[3 + 3 * a] = v[a].z;
    }
    return out;
}

std::vector<NbLight> makeNbLights(const Scene& scene)
{
    std::vector<NbLight> out;
    for (size_t i = 0; i < scene.lights.size(); ++i)
        out.push_back(makeNbLight(scene.lights[i], int(i)));
    return out;
}

}  // namespace nimbus
