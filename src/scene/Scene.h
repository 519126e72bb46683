// Scene.h: the scene model, nimbus's public C++ API for describing what to render.
//
// Everything that renders reads a Scene; everything that reads files, bindings or DCC data
// builds one (DESIGN "data flow"). Units (docs/units.md): metres, radiance W/(m^2 sr) per RGB
// channel, distant-light irradiance W/m^2 on a surface facing the light, point/spot radiant
// intensity W/sr, area/sphere/environment emitted radiance W/(m^2 sr). Angles in degrees.
// Coefficients sigma_s, sigma_a in 1/m at density 1 (Tessendorf sec. 2: b = kappa_b rho).
#pragma once

#include "../../kernels/shared/phase.h"
#include "../core/Transform.h"
#include "../core/Vec.h"
#include "Animation.h"

#include <map>
#include <string>
#include <vector>

namespace nimbus {

// A camera-space depth image whose surfaces hold the volumes out (Tessendorf sec. 8; docs/geometry.md):
// per pixel the distance along the camera's view axis (the Z AOV of production renderers), inf
// or 0 where nothing holds out. Empty file: none.
struct HoldoutDepthFile {
    std::string file;  // resolved against the scene file's directory, as VDB files are
    std::string channel = "Z";
};

struct Camera {
    float3 from = make_float3(0, 0, 5);
    float3 to = make_float3(0, 0, 0);
    float3 up = make_float3(0, 1, 0);
    float fov = 40.0f;  // vertical field of view, degrees
    int width = 640, height = 360;
    // Crop window in fractions of the image, [x0, x1] x [y0, y1], y down from the top.
    float crop[4] = {0, 1, 0, 1};
    // Shutter interval (frames or seconds, only the ratio matters); motion blur is on when
    // hasMotion is set: the camera moves linearly from (from,to,up) to the *Close values.
    float shutterOpen = 0.0f, shutterClose = 0.0f;
    bool hasMotion = false;
    float3 fromClose = make_float3(0, 0, 5), toClose = make_float3(0, 0, 0), upClose = make_float3(0, 1, 0);
    HoldoutDepthFile holdoutDepth;
    // Animation (Animation.h): key lists in place of from, to, up, fov; the values above then
    // hold the first key's until sceneAtFrame evaluates them at the frame (and the shutter).
    Keys<float3> fromKeys, toKeys, upKeys;
    Keys<float> fovKeys;
    // The fov's motion within the shutter (evaluateAnimation, FrameTokens.h; camera.h): its value
    // (degrees) at the shutter's open and close and at every key between, frames after
    // render.frame; `fov` is then the shutter centre's. Empty: the fov holds still over the shutter.
    Keys<float> fovShutterMotion;
};

enum class LightType { Distant, Point, Spot, Rect, Sphere, Environment };

const char* lightTypeName(LightType t);

struct Light {
    std::string name;  // AOV "light_<name>"; defaults to the index in the list
    LightType type = LightType::Distant;
    // distant
    float3 direction = make_float3(0, -1, 0);  // direction of travel (distant, spot axis)
    Rgb irradiance = splat(1.0f);              // W/m^2
    float angle = 0.0f;                        // apparent diameter, degrees
    // point, spot, sphere
    float3 position = make_float3(0, 5, 0);
    Rgb intensity = splat(1.0f);  // W/sr (point, spot)
    float coneAngle = 30.0f;      // spot: full cone angle, degrees
    float coneSoftness = 5.0f;    // spot: width of the falloff inside the cone edge, degrees
    // rect
    float3 center = make_float3(0, 5, 0);
    float3 normal = make_float3(0, -1, 0);  // the side that emits
    float3 up = make_float3(0, 0, 1);
    float size[2] = {1, 1};
    // rect, sphere, environment
    Rgb radiance = splat(1.0f);  // W/(m^2 sr)
    float radius = 0.5f;         // sphere
    // Animation (Animation.h) of the placement keys: direction, position, center, normal, up.
    Keys<float3> directionKeys, positionKeys, centerKeys, normalKeys, upKeys;
    // Motion within the shutter (evaluateAnimation, FrameTokens.h; kernels/shared/motion.h): the
    // placement at the shutter's open and close and at every key between, frames after
    // render.frame. Empty: the light holds still over the shutter.
    struct Pose {
        float3 direction, position, center, normal, up;
    };
    Keys<Pose> shutterMotion;
    // environment: an HDR latitude-longitude map (kernels/shared/envmap.h has the orientation),
    // resolved against the scene file's directory as VDB files are; empty: uniform. The radiance
    // from world direction w is intensity * radiance * map(w).
    std::string map;
    float rotate = 0.0f;     // the map's turn about +y, degrees, counter-clockwise seen from above
    float mapIntensity = 1.0f;  // JSON "intensity" of an environment light: a scalar on the radiance
};

struct Medium {
    Rgb sigma_s = splat(1.0f);  // scattering coefficient at density 1, 1/m
    Rgb sigma_a = splat(0.0f);  // absorption coefficient at density 1, 1/m
    float densityScale = 1.0f;
    NbPhase phase = {0.0f, 0.0f, 0.0f, 0.0f};  // HG g; two-lobe: g2 with weight blend
    float emissionScale = 1.0f;                // multiplies the shader's emission
    // Velocity motion blur (docs/motion-blur.md): 0 leaves the `vel` grid unread; otherwise the
    // grid, in world units per second, times this, moves the density and emission over the
    // shutter: each camera sample at time t reads rho(x - v(x) velocityScale (t - t_frame)).
    float velocityScale = 0.0f;
};

enum class SourceType { Vdb, Procedural, Plugin };

struct VolumeSource {
    SourceType type = SourceType::Procedural;
    // vdb: file and the grid name for each role (density, temperature, flame, Cd, vel)
    std::string file;
    std::map<std::string, std::string> grids;
    // procedural: "cloud", "sphere", "box" with numeric parameters (see docs/scene-format.md)
    std::string generator = "cloud";
    std::map<std::string, double> params;
    // plugin: shared library path and its parameters (strings and numbers kept as text)
    std::string pluginPath;
    std::map<std::string, std::string> pluginParams;
};

struct Volume {
    std::string name;
    VolumeSource source;
    Transform transform;  // worldFromVolume, applied after the grid's own index-to-world
    Keys<Transform> transformKeys;  // animated transform (Animation.h); empty: static
    // Motion within the shutter (evaluateAnimation, FrameTokens.h): the transform at the shutter's
    // open and close and at every key between, frames after render.frame; `transform` is then
    // the shutter centre's. Empty: the volume holds still over the shutter.
    Keys<Transform> shutterMotion;
    Medium medium;
    std::string shader;  // file in shaders/ or a path; empty: the default shader
};

// Opaque, unshaded surfaces in the scene (docs/geometry.md): holdout mattes for camera rays and
// shadow casters for light. Placed by `transform` (worldFromObject, the volumes' key).
enum class GeometryType { Mesh, Sphere, Plane };

const char* geometryTypeName(GeometryType t);  // "mesh", "sphere", "plane"

struct Geometry {
    std::string name;  // defaults to "geometry<i>"
    GeometryType type = GeometryType::Mesh;
    std::string file;     // mesh: OBJ or PLY, resolved against the scene file's directory
    float radius = 1.0f;  // sphere, metres in object space, centred at the object origin
    // plane: the rectangle [-x/2, x/2] x [-z/2, z/2] of the object's y = 0 plane; unbounded
    // (an infinite plane) where `bounded` is false (the JSON key `size` omitted).
    float size[2] = {1, 1};
    bool bounded = false;
    Transform transform;   // worldFromObject
    Keys<Transform> transformKeys;  // animated transform (Animation.h); empty: static
    bool holdout = true;   // camera rays stop at it; it renders black with alpha 0
    bool shadows = true;   // it blocks light (shadow maps, light volumes, light samples)
};

enum class Method { Single, Wkb, Pathtrace, Vrl };

// The progressive, unbiased methods (pathtrace, vrl): they render until spp, a noise target or a
// time limit, keep a running estimate with a variance, write checkpoints and split samples.
inline bool isProgressive(Method m)
{
    return m == Method::Pathtrace || m == Method::Vrl;
}

// vrl: the joint distribution of the point pair of a camera ray and a virtual ray light
// (docs/vrl.md): Oppitz 2018 7.3.1 (simple), 7.3.2 (advanced), or advanced where some phase
// function is anisotropic (auto).
enum class VrlSampling { Auto, Simple, Advanced };

// WKB multiple scattering (docs/wkb.md). The angular kernel per Legendre order j: Tessendorf's
// Gaussian-phase (e^l - 1) A_j(l) (eq. 62-63) or the exact infinite-medium e^{l p_j} - 1.
enum class WkbKernel { Gaussian, Exact };
// Where and how blurred the source Lblur is read for a scattering length l: Tessendorf's
// straight line (sec. 6.3.6) or the mean displacement of an angular random walk.
enum class WkbSource { Straight, RandomWalk };
// How L2+'s second scattering order is computed: traced (a Monte Carlo point on the camera ray,
// a direction from the phase function, and single's march along it; the kernel then carries
// orders 3 and up), as Tessendorf's reduction does, by the angular kernel with the rest, in the
// traced radiance cache with orders 3 and up (cache), or (auto) the cache unless a light's L1 has
// structure the cache's cells cannot hold (src/wkb/WkbPlanner.cpp, chooseOrder2).
enum class WkbOrder2 { Traced, Kernel, Cache, Auto };
// How L2+'s orders 3 and up from the lights are computed: the angular kernel over the blurred light
// pyramid (kernel), or a radiance cache traced from the lights (traced: docs/wkb.md "Orders 3 and
// up, traced"). Emission's L2+ keeps the kernel either way.
enum class WkbOrders3 { Kernel, Traced };

// The pixel reconstruction filter (kernels/shared/filter.h), by filter importance sampling.
enum class PixelFilter { Box, Gaussian, BlackmanHarris };

const char* methodName(Method m);
const char* pixelFilterName(PixelFilter f);  // "box", "gaussian", "blackman_harris"
const char* wkbKernelName(WkbKernel k);      // "gaussian", "exact"
const char* wkbSourceName(WkbSource s);      // "straight", "random_walk"
const char* wkbOrder2Name(WkbOrder2 o);      // "traced", "kernel", "cache", "auto"
const char* wkbOrders3Name(WkbOrders3 o);    // "kernel", "traced"
const char* vrlSamplingName(VrlSampling s);  // "auto", "simple", "advanced"

// Samples per pixel of single and wkb when `spp` is 0 (the default).
constexpr int kDefaultMarchSpp = 4;

struct RenderSettings {
    Method method = Method::Single;
    uint32_t seed = 1;
    // The frame rendered: replaces the frame tokens ($F, $F4, ####) of every path (FrameTokens.h).
    int frame = 1;
    // Frames per second of the shot: turns the shutter (in frames) into seconds for velocity
    // motion blur (vel grids are in world units per second, as Houdini, Arnold and Karma write them).
    float fps = 24.0f;
    int threads = 0;  // 0: all cores
    // Camera samples per pixel (single, wkb); path samples per pixel (pathtrace). 0: the method's
    // default, kDefaultMarchSpp for single and wkb, and for pathtrace no sample count (it renders
    // until noiseTarget or timeLimit).
    int spp = 0;
    // single, wkb: adaptive sampling (AdaptiveSampling.h): a pixel whose mean's relative standard
    // error is above adaptiveThreshold takes more samples, up to adaptiveMaxSpp (0: 4 x spp).
    // adaptiveThreshold 0: every pixel takes spp.
    double adaptiveThreshold = 0.05;
    int adaptiveMaxSpp = 0;
    PixelFilter pixelFilter = PixelFilter::Gaussian;
    float filterWidth = 2.0f;  // the filter's full support, pixels (radius width / 2)
    float step = 0.5f;         // primary march step as a fraction of the smallest voxel
    int shadowMapResolution = 256;
    float tolerance = 0.002f;   // deep-shadow-map transmittance error, and term cut-offs
    float shadowStep = 1.0f;    // light-ray march step for shadow maps and light sampling, voxels
    int lightSamples = 1;       // area, sphere and environment light samples per march step
    int emissionSamples = 4;    // single, wkb: samples of emission's single scattering per camera ray
    int maxDepth = 0;           // pathtrace: the most scattering events; 0 = unbounded, 1 = single scattering
    double timeLimit = 0.0;     // pathtrace: seconds, 0 = none
    double noiseTarget = 1e-4;  // pathtrace with spp 0: stop at this beauty relMSE (from the variance AOV); 0 = none
    // pathtrace: equi-angular sampling towards point and spot lights, combined with distance
    // sampling by MIS (docs/pathtracer.md); no effect without such lights.
    bool equiangular = true;
    // vrl (docs/vrl.md): light paths per iteration (each iteration is one sample per pixel that
    // gathers from all their segments) and the joint distribution of the gather.
    int vrlPaths = 16;
    VrlSampling vrlSampling = VrlSampling::Auto;
    // wkb (docs/wkb.md has the derivation of each):
    WkbKernel wkbKernel = WkbKernel::Exact;
    WkbSource wkbSource = WkbSource::RandomWalk;
    WkbOrder2 wkbOrder2 = WkbOrder2::Auto;    // order 2 of L2+ (docs/wkb.md "Which order-2 model")
    int wkbOrder2Samples = 4;                 // traced order-2 samples per camera ray
    WkbOrders3 wkbOrders3 = WkbOrders3::Traced;  // orders 3+ of the lights' L2+ (docs/wkb.md)
    int wkbOrders3Paths = 0;                     // traced: light paths of the radiance cache; 0: from its measured noise (traceOrders3)
    int wkbOrders3Grid = 0;                      // traced: cache cells along the volumes' longest side (0: automatic)
    float wkbBlurK = 24.0f;         // K in the blur width s sqrt(K mu l), Tessendorf eq. 79
    float wkbLStep = 0.25f;         // l-march step, scattering lengths; grows as l_step * l past l = 1
    int wkbOrderMax = 128;          // cap on the Legendre order j of the angular sum (eq. 88)
    int wkbShOrderMax = 2;          // cap on the SH order of area, environment and emission light volumes
    int lightVolumeResolution = 0;  // light-grid voxels across a volume's largest extent; 0: the plan picks
    float wkbMemoryBudget = 1.0f;   // all light pyramids / all density grids, bytes (automatic resolution)
    float memoryLimit = 0.0f;       // bytes the render may use (estimated before); 0: 80% of physical memory
};

struct OutputSettings {
    std::string file = "out/render.exr";
    std::string preview;            // PNG through the OCIO view; empty: none
    std::string previewView;        // the preview's OCIO view of the default display; empty: its default view
    std::string previewLook;        // an OCIO look applied before the view; empty: none
    float exposure = 0.0f;          // the preview's exposure, stops: scene-linear x 2^exposure before the view
    std::vector<std::string> aovs;  // empty: all the method produces
    // Deep scanline OpenEXR (docs/output.md "Deep output"): samples along each camera ray;
    // empty: none. single and wkb only.
    std::string deep;
    int deepSamples = 32;  // the most deep samples per pixel (depth slices of the volumes)
};

struct Scene {
    Camera camera;
    std::vector<Light> lights;
    std::vector<Volume> volumes;
    std::vector<Geometry> geometry;
    RenderSettings render;
    OutputSettings output;
    Rgb background = splat(0.0f);  // radiance behind the volumes when no environment light
    std::string sourcePath;        // the JSON file it came from, for messages; may be empty
};

}  // namespace nimbus
