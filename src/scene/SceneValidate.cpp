// SceneValidate.cpp: range checks, one function per part of the scene. Key paths are spelled
// as in the JSON format (docs/scene-format.md) because that is the parameter vocabulary users
// know, whichever client built the Scene.
#include "SceneValidate.h"

#include "../core/Error.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

namespace nimbus {

void throwSceneError(const std::string& file, const std::string& keyPath, const std::string& what)
{
    std::string message;
    if (!file.empty())
        message += file + ": ";
    if (!keyPath.empty())
        message += keyPath + ": ";
    throw InputError(message + what);
}

namespace {

std::string num(double v)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

std::string vec(float3 v)
{
    return "[" + num(v.x) + ", " + num(v.y) + ", " + num(v.z) + "]";
}

bool isNameChar(char c)
{
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
}

// One interval with open or closed ends, written in the message the way a user reads ranges.
struct Range {
    double lo, hi;
    bool loOpen, hiOpen;
    const char* units;

    bool contains(double v) const
    {
        // Written so that NaN fails every comparison and is rejected.
        bool aboveLo = loOpen ? v > lo : v >= lo;
        bool belowHi = hiOpen ? v < hi : v <= hi;
        return aboveLo && belowHi;
    }
    std::string text() const
    {
        std::string s = std::string(loOpen ? "(" : "[") + (std::isinf(lo) ? "-inf" : num(lo)) + ", " +
                        (std::isinf(hi) ? "inf" : num(hi)) + (hiOpen ? ")" : "]");
        if (units && *units)
            s += std::string(" ") + units;
        return s;
    }
};

const double kInf = INFINITY;
const Range kAngle{0, 180, true, true, "degrees"};
const double kMinFov = 1e-30;  // degrees
const Range kPositive{0, kInf, true, true, ""};
const Range kNonNegative{0, kInf, false, true, ""};
// |g| = 1 is a delta phase function that HG sampling cannot represent; 0.999 is the documented cap.
const Range kAsymmetry{-0.999, 0.999, false, false, ""};

class Checker {
public:
    explicit Checker(const std::string& file) : mFile(file) {}

    [[noreturn]] void fail(const std::string& path, const std::string& what) const
    {
        throwSceneError(mFile, path, what);
    }
    void range(const std::string& path, double v, const Range& r) const
    {
        if (!r.contains(v))
            fail(path, "must be in " + r.text() + ", got " + num(v));
    }
    void atLeast(const std::string& path, long long v, long long lo) const
    {
        if (v < lo)
            fail(path, "must be at least " + std::to_string(lo) + ", got " + std::to_string(v));
    }
    void finite(const std::string& path, float3 v) const
    {
        if (!isFinite(v))
            fail(path, "must be finite, got " + vec(v));
    }
    void direction(const std::string& path, float3 v) const
    {
        finite(path, v);
        if (v.x == 0 && v.y == 0 && v.z == 0)
            fail(path, "must be a non-zero vector");
    }
    // Radiometric quantities and coefficients: a negative value would add energy to a medium
    // or subtract light, which no integrator is written to handle.
    void nonNegative(const std::string& path, float3 v) const
    {
        if (!isFinite(v) || v.x < 0 || v.y < 0 || v.z < 0)
            fail(path, "must be non-negative and finite, got " + vec(v));
    }
    // Both non-zero (checked before) and not parallel: the cross product must be a usable axis.
    void notParallel(const std::string& path, float3 a, float3 b, const std::string& other) const
    {
        float3 c = cross(normalize(a), normalize(b));
        if (!(length(c) > 1e-5f))
            fail(path, "must not be parallel to " + other + ", got " + vec(a) + " and " + vec(b));
    }

private:
    const std::string& mFile;
};

void checkPose(const Checker& c, const std::string& prefix, float3 from, float3 to, float3 up)
{
    c.finite(prefix + "from", from);
    c.finite(prefix + "to", to);
    c.direction(prefix + "up", up);
    float3 view = to - from;
    if (view.x == 0 && view.y == 0 && view.z == 0)
        c.fail(prefix + "to",
               "must differ from " + prefix + "from (a camera cannot look at its own position), got " + vec(to));
    c.notParallel(prefix + "up", up, view, "the view direction (to - from)");
}

void checkCamera(const Checker& c, const Camera& cam)
{
    checkPose(c, "camera.", cam.from, cam.to, cam.up);
    c.range("camera.fov", cam.fov, kAngle);
    // Below 1e-30 degrees tan(fov / 2) is no longer a normal float and every camera ray is the
    // same ray.
    if (cam.fov < kMinFov)
        c.fail("camera.fov", "must be at least " + num(kMinFov) + " degrees, got " + num(cam.fov));
    if (cam.width < 1 || cam.height < 1 || cam.width > 65536 || cam.height > 65536)
        c.fail("camera.resolution", "must be two positive integers <= 65536, got [" + std::to_string(cam.width) + ", " +
                                        std::to_string(cam.height) + "]");
    const float* k = cam.crop;
    bool inUnit = true;
    for (int i = 0; i < 4; ++i)
        inUnit = inUnit && k[i] >= 0 && k[i] <= 1;
    if (!inUnit || !(k[0] < k[1]) || !(k[2] < k[3]))
        c.fail("camera.crop", "must be [x0, x1, y0, y1] within [0, 1] with x0 < x1 and y0 < y1, got [" + num(k[0]) +
                                  ", " + num(k[1]) + ", " + num(k[2]) + ", " + num(k[3]) + "]");
    if (!std::isfinite(cam.shutterOpen) || !std::isfinite(cam.shutterClose) || cam.shutterOpen > cam.shutterClose)
        c.fail("camera.shutter", "must be finite [open, close] with open <= close, got [" + num(cam.shutterOpen) +
                                     ", " + num(cam.shutterClose) + "]");
    if (cam.hasMotion)
        checkPose(c, "camera.motion.", cam.fromClose, cam.toClose, cam.upClose);
    if (!cam.holdoutDepth.file.empty() && cam.holdoutDepth.channel.empty())
        c.fail("camera.holdout_depth.channel", "must not be empty");
}

void checkLight(const Checker& c, const Light& l, const std::string& p)
{
    switch (l.type) {
    case LightType::Distant:
        c.direction(p + "direction", l.direction);
        c.nonNegative(p + "irradiance", l.irradiance);
        c.range(p + "angle", l.angle, Range{0, 180, false, true, "degrees"});
        break;
    case LightType::Point:
        c.finite(p + "position", l.position);
        c.nonNegative(p + "intensity", l.intensity);
        break;
    case LightType::Spot:
        c.finite(p + "position", l.position);
        c.direction(p + "direction", l.direction);
        c.nonNegative(p + "intensity", l.intensity);
        c.range(p + "cone_angle", l.coneAngle, kAngle);
        c.range(p + "cone_softness", l.coneSoftness, Range{0, l.coneAngle, false, false, "degrees (up to cone_angle)"});
        break;
    case LightType::Rect:
        c.finite(p + "center", l.center);
        c.direction(p + "normal", l.normal);
        c.direction(p + "up", l.up);
        c.notParallel(p + "up", l.up, l.normal, "the normal");
        c.range(p + "size[0]", l.size[0], kPositive);
        c.range(p + "size[1]", l.size[1], kPositive);
        c.nonNegative(p + "radiance", l.radiance);
        break;
    case LightType::Sphere:
        c.finite(p + "position", l.position);
        c.range(p + "radius", l.radius, kPositive);
        c.nonNegative(p + "radiance", l.radiance);
        break;
    case LightType::Environment:
        c.nonNegative(p + "radiance", l.radiance);
        c.range(p + "rotate", l.rotate, Range{-kInf, kInf, true, true, "degrees"});
        c.range(p + "intensity", l.mapIntensity, kNonNegative);
        break;
    default: c.fail(p + "type", "unknown light type " + std::to_string(int(l.type)));
    }
}

void checkLights(const Checker& c, const std::vector<Light>& lights)
{
    std::set<std::string> names;
    for (size_t i = 0; i < lights.size(); ++i) {
        const Light& l = lights[i];
        std::string p = "lights[" + std::to_string(i) + "].";
        bool valid = !l.name.empty();
        for (char ch : l.name)
            valid = valid && isNameChar(ch);
        if (!valid)
            c.fail(p + "name", "must match [A-Za-z0-9_]+ (it names the AOV light_<name>), got '" + l.name + "'");
        if (!names.insert(l.name).second)
            c.fail(p + "name", "'" + l.name + "' names another light too; light names must be unique");
        checkLight(c, l, p);
    }
    // The path tracer samples one map (kernels/pathtrace.cl): a second sky map is a mistake to
    // report, not a light to drop.
    int maps = 0;
    for (size_t i = 0; i < lights.size(); ++i)
        if (!lights[i].map.empty() && ++maps > 1)
            c.fail("lights[" + std::to_string(i) + "].map",
                   "a second environment map; a scene may have one (add the skies into one map)");
}

// Grid roles a VDB source can map (DESIGN "Units and conventions"); "heat" is read as "flame".
bool isGridRole(const std::string& role)
{
    return role == "density" || role == "temperature" || role == "flame" || role == "Cd" || role == "vel";
}

void checkSource(const Checker& c, const VolumeSource& s, const std::string& p)
{
    switch (s.type) {
    case SourceType::Vdb:
        if (s.file.empty())
            c.fail(p + "file", "a vdb source needs a file");
        for (const auto& [role, grid] : s.grids) {
            if (!isGridRole(role))
                c.fail(p + "grids." + role, "unknown grid role (expected density, temperature, flame, Cd, vel)");
            if (grid.empty())
                c.fail(p + "grids." + role, "grid name must not be empty");
        }
        break;
    case SourceType::Procedural:
        if (s.generator != "cloud" && s.generator != "sphere" && s.generator != "box")
            c.fail(p + "generator", "unknown generator '" + s.generator + "' (expected cloud, sphere, box)");
        for (const auto& [key, value] : s.params)
            if (!std::isfinite(value))
                c.fail(p + key, "must be finite, got " + num(value));
        break;
    case SourceType::Plugin:
        if (s.pluginPath.empty())
            c.fail(p + "path", "a plugin source needs the path of its shared library");
        break;
    default: c.fail(p + "type", "unknown source type " + std::to_string(int(s.type)));
    }
}

void checkTransform(const Checker& c, const Transform& t, const std::string& path, const char* what = "the volume")
{
    const auto& m = t.rowMajor();
    for (double v : m)
        if (!std::isfinite(v))
            c.fail(path, "must be finite, got an entry " + num(v));
    if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1)
        c.fail(path, "must be affine: the last row of the row-major matrix must be [0, 0, 0, 1], got [" + num(m[12]) +
                         ", " + num(m[13]) + ", " + num(m[14]) + ", " + num(m[15]) + "]");
    if (t.isSingular())
        c.fail(path, std::string("is singular (a zero scale?); ") + what + " would have no extent");
}

}  // namespace

double maxExtinctionAtDensityOne(const Medium& m)
{
    double extinction = 0.0;
    for (int ch = 0; ch < 3; ++ch)
        extinction = std::max(extinction, (double(component(m.sigma_s, ch)) + double(component(m.sigma_a, ch))) *
                                              double(m.densityScale));
    return extinction;
}

namespace {

void checkMedium(const Checker& c, const Medium& m, const std::string& p)
{
    c.nonNegative(p + "sigma_s", m.sigma_s);
    c.nonNegative(p + "sigma_a", m.sigma_a);
    c.range(p + "density_scale", m.densityScale, kNonNegative);
    // Overflow up front (in double: the float product may already be inf): the grid's voxels
    // are checked against the same bound once loaded (VdbLoad.cpp).
    const double extinction = maxExtinctionAtDensityOne(m);
    if (!(extinction <= kMaxExtinction))
        c.fail(p + "density_scale", "the extinction (sigma_s + sigma_a) * density_scale = " + num(extinction) +
                                        " 1/m at density 1 is beyond the " + num(kMaxExtinction) +
                                        " 1/m nimbus renders in float; lower density_scale, sigma_s or sigma_a");
    c.range(p + "emission_scale", m.emissionScale, kNonNegative);
    // Any finite number: negative runs the motion backwards, as Arnold's velocity_scale does.
    c.range(p + "velocity_scale", m.velocityScale, Range{-kInf, kInf, true, true, ""});
    c.range(p + "phase.g", m.phase.g, kAsymmetry);
    c.range(p + "phase.g2", m.phase.g2, kAsymmetry);
    c.range(p + "phase.blend", m.phase.blend, Range{0, 1, false, false, ""});
}

void checkVolumes(const Checker& c, const std::vector<Volume>& volumes)
{
    for (size_t i = 0; i < volumes.size(); ++i) {
        const Volume& v = volumes[i];
        std::string p = "volumes[" + std::to_string(i) + "].";
        if (v.name.empty())
            c.fail(p + "name", "must not be empty");
        checkSource(c, v.source, p + "source.");
        checkTransform(c, v.transform, p + "transform");
        checkMedium(c, v.medium, p + "medium.");
    }
}

void checkGeometry(const Checker& c, const std::vector<Geometry>& geometry)
{
    for (size_t i = 0; i < geometry.size(); ++i) {
        const Geometry& g = geometry[i];
        std::string p = "geometry[" + std::to_string(i) + "].";
        if (g.name.empty())
            c.fail(p + "name", "must not be empty");
        switch (g.type) {
        case GeometryType::Mesh:
            if (g.file.empty())
                c.fail(p + "file", "a mesh needs a file (OBJ or PLY)");
            break;
        case GeometryType::Sphere: c.range(p + "radius", g.radius, kPositive); break;
        case GeometryType::Plane:
            if (g.bounded) {
                c.range(p + "size[0]", g.size[0], kPositive);
                c.range(p + "size[1]", g.size[1], kPositive);
            }
            break;
        default: c.fail(p + "type", "unknown geometry type " + std::to_string(int(g.type)));
        }
        checkTransform(c, g.transform, p + "transform", "the object");
    }
}

void checkRender(const Checker& c, const RenderSettings& r)
{
    c.atLeast("render.threads", r.threads, 0);
    // spp 0 is the method's default: 4 samples for single and wkb; for the path tracer no sample
    // count, so the noise target or the time limit must end the render.
    c.atLeast("render.spp", r.spp, 0);
    c.range("render.adaptive_threshold", r.adaptiveThreshold, Range{0, 1, false, false, "relative standard error"});
    c.range("render.adaptive_max_spp", r.adaptiveMaxSpp, Range{0, 1 << 24, false, false, "samples per pixel"});
    c.range("render.filter_width", r.filterWidth, Range{0, 16, true, false, "pixels"});
    // A floor, not 0: a finer camera step changes the image by less than float rounding and only
    // multiplies the march's time (at 1e-9 voxels a render made no progress for minutes: issue 18,
    // failure 6), so such a step is refused naming the key rather than rendered for hours.
    c.range("render.step", r.step, Range{kMinRenderStep, 100, false, false, "voxels"});
    c.range("render.shadow_map_resolution", r.shadowMapResolution, Range{8, 16384, false, false, "texels"});
    c.range("render.tolerance", r.tolerance, Range{0, 0.5, true, false, ""});
    c.range("render.shadow_step", r.shadowStep, Range{0, 100, true, false, "voxels"});
    c.atLeast("render.light_samples", r.lightSamples, 1);
    c.atLeast("render.max_depth", r.maxDepth, 0);
    c.range("render.fps", r.fps, Range{0, kInf, true, true, "frames per second"});
    c.range("render.time_limit", r.timeLimit, Range{0, kInf, false, true, "seconds"});
    c.range("render.noise_target", r.noiseTarget, Range{0, 1, false, false, "relMSE"});
    if (isProgressive(r.method) && r.spp == 0 && r.noiseTarget == 0 && r.timeLimit == 0)
        c.fail("render.noise_target", std::string(methodName(r.method)) +
                                          " with spp 0 needs a noise_target or a time_limit to end the render");
    c.range("render.vrl_paths", r.vrlPaths, Range{1, 4096, false, false, "light paths per iteration"});
    c.range("render.wkb_blur_k", r.wkbBlurK, Range{0, 1000, true, false, "(Tessendorf eq. 79: 24)"});
    c.range("render.wkb_l_step", r.wkbLStep, Range{0, 10, true, false, "scattering lengths"});
    c.range("render.wkb_order_max", r.wkbOrderMax, Range{0, 4096, false, false, ""});
    c.range("render.emission_samples", r.emissionSamples, Range{1, 1024, false, false, "per camera ray"});
    c.range("render.wkb_order2_samples", r.wkbOrder2Samples, Range{1, 1024, false, false, "per camera ray"});
    c.range("render.wkb_orders3_paths", r.wkbOrders3Paths, Range{0, 1 << 26, false, false, "light paths (0: from the image)"});
    if (r.wkbOrders3Grid != 0)
        c.range("render.wkb_orders3_grid", r.wkbOrders3Grid, Range{2, 512, false, false, "cells (0: automatic)"});
    c.range("render.wkb_sh_order_max", r.wkbShOrderMax, Range{0, 8, false, false, ""});
    if (r.lightVolumeResolution != 0)
        c.range("render.light_volume_resolution", r.lightVolumeResolution,
                Range{4, 4096, false, false, "voxels (0: automatic)"});
    c.range("render.wkb_memory_budget", r.wkbMemoryBudget,
            Range{0, 100, true, false, "times the density grids' memory"});
    c.range("render.memory_limit", r.memoryLimit, Range{0, kInf, false, true, "bytes (0: 80% of physical memory)"});
}

void checkOutput(const Checker& c, const OutputSettings& o)
{
    std::set<std::string> seen;
    for (size_t i = 0; i < o.aovs.size(); ++i) {
        std::string p = "output.aovs[" + std::to_string(i) + "]";
        if (o.aovs[i].empty())
            c.fail(p, "must not be empty");
        if (!seen.insert(o.aovs[i]).second)
            c.fail(p, "'" + o.aovs[i] + "' is listed twice");
    }
    // 2^64 overflows nothing a preview shows; beyond that only a typo gets here.
    c.range("output.exposure", o.exposure, Range{-64, 64, false, false, "stops"});
    c.range("output.deep_samples", o.deepSamples, Range{1, 1024, false, false, "samples per pixel"});
}

}  // namespace

void validateScene(const Scene& scene)
{
    Checker c(scene.sourcePath);
    checkCamera(c, scene.camera);
    checkLights(c, scene.lights);
    checkVolumes(c, scene.volumes);
    checkGeometry(c, scene.geometry);
    checkRender(c, scene.render);
    checkOutput(c, scene.output);
    // The path tracer's paths are not binned along their primary rays (docs/output.md).
    if (!scene.output.deep.empty() && scene.render.method == Method::Pathtrace)
        c.fail("output.deep", "deep output is written by methods single and wkb, not pathtrace");
    c.nonNegative("background", scene.background);
}

void applyDefaultNames(Scene& scene)
{
    for (size_t i = 0; i < scene.lights.size(); ++i)
        if (scene.lights[i].name.empty())
            scene.lights[i].name = std::to_string(i);
    for (size_t i = 0; i < scene.volumes.size(); ++i)
        if (scene.volumes[i].name.empty())
            scene.volumes[i].name = "volume" + std::to_string(i);
    for (size_t i = 0; i < scene.geometry.size(); ++i)
        if (scene.geometry[i].name.empty())
            scene.geometry[i].name = "geometry" + std::to_string(i);
}

}  // namespace nimbus
