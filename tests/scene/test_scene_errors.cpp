// Every class of scene input error: one line naming the file and the key path.
#include "core/Error.h"
#include "scene/JsonReader.h"
#include "scene/SceneJson.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

#include <sys/stat.h>
#include <unistd.h>

using namespace nimbus;
using nlohmann::json;

namespace {

// The message sceneFromJson throws for a document; fails the test if it throws nothing or
// anything but an InputError, or if the message is not one line naming scene.json.
std::string errorOf(const std::string& text)
{
    try {
        sceneFromJson(json::parse(text), "scene.json");
    } catch (const InputError& e) {
        std::string m = e.what();
        EXPECT_EQ(m.rfind("scene.json: ", 0), 0u) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
        return m;
    }
    ADD_FAILURE() << "no InputError for " << text;
    return "";
}

#define EXPECT_ERROR(text, expected)                                                                                   \
    do {                                                                                                               \
        std::string message_ = errorOf(text);                                                                          \
        EXPECT_NE(message_.find(expected), std::string::npos) << message_;                                             \
    } while (0)

const char* kSource = R"("source": {"type": "procedural"})";

std::string volume(const std::string& body)
{
    return R"({"volumes": [{)" + std::string(kSource) + body + "}]}";
}
std::string light(const std::string& body)
{
    return R"({"lights": [{)" + body + "}]}";
}

}  // namespace

TEST(SceneErrors, ExactMessagesOfTheFormatDocument)
{
    EXPECT_EQ(errorOf(R"({"camera": {"fov": 0}})"), "scene.json: camera.fov: must be in (0, 180) degrees, got 0");
    EXPECT_EQ(errorOf(R"({"lights": [{"type": "point"}, {"type": "laser"}]})"),
              "scene.json: lights[1].type: unknown light type 'laser' (expected distant, point, spot, rect, sphere, "
              "environment)");
    EXPECT_EQ(errorOf(volume(R"(, "medium": {"sigma_s": "blue"})")),
              "scene.json: volumes[0].medium.sigma_s: expected an RGB array of 3 numbers or a number, got string");
    EXPECT_EQ(errorOf(R"({"render": {"bogus": 1}})"), "scene.json: render.bogus: unknown key");
}

TEST(SceneErrors, UnknownKeysAtEveryLevel)
{
    EXPECT_ERROR(R"({"camra": {}})", "scene.json: camra: unknown key (did you mean 'camera'?)");
    EXPECT_ERROR(R"({"camera": {"fovy": 30}})", "camera.fovy: unknown key");
    EXPECT_ERROR(R"({"camera": {"motion": {"fov": 30}}})", "camera.motion.fov: unknown key");
    EXPECT_ERROR(R"({"render": {"sp": 4}})", "render.sp: unknown key (did you mean 'spp'?)");
    EXPECT_ERROR(R"({"output": {"exr": "a.exr"}})", "output.exr: unknown key");
    EXPECT_ERROR(light(R"("type": "point", "cone_angle": 30)"), "lights[0].cone_angle: unknown key for a point light");
    EXPECT_ERROR(volume(R"(, "densty": 1)"), "volumes[0].densty: unknown key");
    EXPECT_ERROR(volume(R"(, "medium": {"albedo": 1})"), "volumes[0].medium.albedo: unknown key");
    EXPECT_ERROR(volume(R"(, "medium": {"phase": {"k": 1}})"), "volumes[0].medium.phase.k: unknown key");
    EXPECT_ERROR(volume(R"(, "transform": {"shear": 1})"), "volumes[0].transform.shear: unknown key");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "vdb", "file": "a.vdb", "radius": 1}}]})",
                 "volumes[0].source.radius: unknown key for a vdb source");
}

TEST(SceneErrors, WrongTypes)
{
    EXPECT_ERROR(R"({"camera": {"fov": "wide"}})", "camera.fov: expected a number, got string");
    EXPECT_ERROR(R"({"camera": {"from": [1, 2]}})", "camera.from: expected an array of 3 numbers, got an array of 2");
    EXPECT_ERROR(R"({"camera": {"to": [1, "x", 2]}})", "camera.to[1]: expected a number, got string");
    EXPECT_ERROR(R"({"camera": {"resolution": 640}})", "camera.resolution: expected [width, height]");
    EXPECT_ERROR(R"({"camera": {"resolution": [640.5, 360]}})", "camera.resolution[0]: expected an integer");
    EXPECT_ERROR(R"({"camera": 5})", "camera: expected an object, got number");
    EXPECT_ERROR(R"({"lights": {}})", "lights: expected a list, got object");
    EXPECT_ERROR(R"({"lights": [3]})", "lights[0]: expected an object, got number");
    EXPECT_ERROR(light(R"("type": "distant", "irradiance": [1, 1])"),
                 "lights[0].irradiance: expected an RGB array of 3 numbers or a number, got an array of 2");
    EXPECT_ERROR(light(R"("type": "point", "name": 3)"), "lights[0].name: expected a string, got number");
    EXPECT_ERROR(R"({"render": {"spp": true}})", "render.spp: expected an integer, got boolean");
    EXPECT_ERROR(R"({"render": {"spp": 2.5}})", "render.spp: expected an integer, got 2.5");
    EXPECT_ERROR(R"({"render": {"seed": -1}})", "render.seed: must be an integer in [0, 4294967295]");
    EXPECT_ERROR(R"({"output": {"aovs": "beauty"}})", "output.aovs: expected a list of strings, got string");
    EXPECT_ERROR(R"({"output": {"aovs": ["beauty", 1]}})", "output.aovs[1]: expected a string, got number");
    EXPECT_ERROR(R"({"background": null})", "background: expected an RGB array of 3 numbers or a number, got null");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "procedural", "radius": "big"}}]})",
                 "volumes[0].source.radius: expected a number, got string");
    EXPECT_ERROR(volume(R"(, "transform": [1, 0, 0])"), "volumes[0].transform: expected a row-major matrix of 16");
    EXPECT_ERROR(volume(R"(, "transform": {"rotate": [90, 0, 1]})"), "volumes[0].transform.rotate: expected [angle");
    EXPECT_ERROR(volume(R"(, "transform": "identity")"), "volumes[0].transform: expected a row-major matrix");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "plugin", "path": "a.so", "params": {"on": true}}}]})",
                 "volumes[0].source.params.on: expected a string or a number, got boolean");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "vdb", "file": "a.vdb", "grids": {"density": 1}}}]})",
                 "volumes[0].source.grids.density: expected a string, got number");
    EXPECT_ERROR("[]", "scene.json: expected an object, got an array of 0");
}

TEST(SceneErrors, UnknownNames)
{
    EXPECT_ERROR(R"({"render": {"method": "raytrace"}})",
                 "render.method: unknown method 'raytrace' (expected single, wkb, pathtrace, vrl)");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "houdini"}}]})",
                 "volumes[0].source.type: unknown source type 'houdini' (expected vdb, procedural, plugin)");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "procedural", "generator": "torus"}}]})",
                 "volumes[0].source.generator: unknown generator 'torus' (expected cloud, sphere, box)");
    EXPECT_ERROR(volume(R"(, "medium": {"phase": {"type": "rayleigh"}})"),
                 "volumes[0].medium.phase.type: unknown phase function 'rayleigh'");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "vdb", "file": "a.vdb", "grids": {"colour": "Cd"}}}]})",
                 "volumes[0].source.grids.colour: unknown grid role");
    EXPECT_ERROR(R"({"version": 2})", "version: this nimbus reads scene format version 1, got 2");
}

TEST(SceneErrors, RequiredKeys)
{
    EXPECT_ERROR(light(R"("name": "key")"), "lights[0].type: required key is missing");
    EXPECT_ERROR(R"({"volumes": [{"name": "cloud"}]})", "volumes[0].source: required key is missing");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "vdb"}}]})", "volumes[0].source.file: required key is missing");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "plugin"}}]})", "volumes[0].source.path: required key is missing");
    EXPECT_ERROR(R"({"volumes": [{"source": {"generator": "cloud"}}]})", "volumes[0].source.type: required key");
    EXPECT_ERROR(R"({"volumes": [{"source": {"type": "vdb", "file": ""}}]})", "volumes[0].source.file: a vdb source");
}

TEST(SceneErrors, CameraRanges)
{
    EXPECT_ERROR(R"({"camera": {"fov": 180}})", "camera.fov: must be in (0, 180) degrees, got 180");
    EXPECT_ERROR(R"({"camera": {"resolution": [0, 360]}})", "camera.resolution: must be two positive integers");
    EXPECT_ERROR(R"({"camera": {"resolution": [65537, 360]}})", "camera.resolution: must be two positive integers");
    EXPECT_ERROR(R"({"camera": {"from": [1, 2, 3], "to": [1, 2, 3]}})", "camera.to: must differ from camera.from");
    EXPECT_ERROR(R"({"camera": {"from": [0, 5, 0], "to": [0, 0, 0]}})", "camera.up: must not be parallel");
    EXPECT_ERROR(R"({"camera": {"up": [0, 0, 0]}})", "camera.up: must be a non-zero vector");
    EXPECT_ERROR(R"({"camera": {"crop": [0.5, 0.5, 0, 1]}})", "camera.crop: must be [x0, x1, y0, y1] within [0, 1]");
    EXPECT_ERROR(R"({"camera": {"crop": [0, 1, -0.1, 1]}})", "camera.crop: must be");
    EXPECT_ERROR(R"({"camera": {"shutter": [1, 0]}})",
                 "camera.shutter: must be finite [open, close] with open <= close");
    EXPECT_ERROR(R"({"camera": {"motion": {"to": [0, 0, 5]}}})",
                 "camera.motion.to: must differ from camera.motion.from");
}

TEST(SceneErrors, LightRanges)
{
    EXPECT_ERROR(light(R"("type": "distant", "direction": [0, 0, 0])"), "lights[0].direction: must be a non-zero");
    EXPECT_ERROR(light(R"("type": "distant", "irradiance": [1, -1, 1])"),
                 "lights[0].irradiance: must be non-negative and finite, got [1, -1, 1]");
    EXPECT_ERROR(light(R"("type": "distant", "angle": -1)"), "lights[0].angle: must be in [0, 180) degrees");
    EXPECT_ERROR(light(R"("type": "point", "intensity": -2)"), "lights[0].intensity: must be non-negative");
    EXPECT_ERROR(light(R"("type": "spot", "cone_angle": 0)"), "lights[0].cone_angle: must be in (0, 180) degrees");
    EXPECT_ERROR(light(R"("type": "spot", "cone_angle": 20, "cone_softness": 25)"),
                 "lights[0].cone_softness: must be in [0, 20] degrees");
    EXPECT_ERROR(light(R"("type": "spot", "cone_softness": -1)"), "lights[0].cone_softness: must be in [0, 30]");
    EXPECT_ERROR(light(R"("type": "rect", "size": [1, 0])"), "lights[0].size[1]: must be in (0, inf), got 0");
    EXPECT_ERROR(light(R"("type": "rect", "normal": [0, 0, 0])"), "lights[0].normal: must be a non-zero vector");
    EXPECT_ERROR(light(R"("type": "rect", "normal": [0, 0, 1], "up": [0, 0, -2])"),
                 "lights[0].up: must not be parallel to the normal");
    EXPECT_ERROR(light(R"("type": "sphere", "radius": 0)"), "lights[0].radius: must be in (0, inf), got 0");
    EXPECT_ERROR(light(R"("type": "environment", "radiance": -0.5)"), "lights[0].radiance: must be non-negative");
    EXPECT_ERROR(light(R"("type": "point", "name": "key light")"), "lights[0].name: must match [A-Za-z0-9_]+");
    EXPECT_ERROR(light(R"("type": "point", "name": "")"), "lights[0].name: must match [A-Za-z0-9_]+");
    EXPECT_ERROR(R"({"lights": [{"type": "point", "name": "1"}, {"type": "point"}]})",
                 "lights[1].name: '1' names another light too");
}

TEST(SceneErrors, MediumRanges)
{
    EXPECT_ERROR(volume(R"(, "medium": {"sigma_s": -1})"), "volumes[0].medium.sigma_s: must be non-negative");
    EXPECT_ERROR(volume(R"(, "medium": {"sigma_a": [0, 0, -0.1]})"), "volumes[0].medium.sigma_a: must be non-negative");
    EXPECT_ERROR(volume(R"(, "medium": {"density_scale": -1})"),
                 "volumes[0].medium.density_scale: must be in [0, inf)");
    EXPECT_ERROR(volume(R"(, "medium": {"emission_scale": -1})"), "volumes[0].medium.emission_scale: must be in [0");
    EXPECT_ERROR(volume(R"(, "medium": {"phase": {"g": 1}})"),
                 "volumes[0].medium.phase.g: must be in [-0.999, 0.999], got 1");
    EXPECT_ERROR(volume(R"(, "medium": {"phase": {"type": "hg2", "g2": -1}})"), "volumes[0].medium.phase.g2: must be");
    EXPECT_ERROR(volume(R"(, "medium": {"phase": {"type": "hg2", "blend": 1.5}})"),
                 "volumes[0].medium.phase.blend: must be in [0, 1], got 1.5");
}

TEST(SceneErrors, Transforms)
{
    EXPECT_ERROR(volume(R"(, "transform": {"scale": 0})"), "volumes[0].transform: is singular");
    EXPECT_ERROR(volume(R"(, "transform": {"scale": [1, 0, 1]})"), "volumes[0].transform: is singular");
    EXPECT_ERROR(volume(R"(, "transform": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1])"),
                 "volumes[0].transform: must be affine");
    EXPECT_ERROR(volume(R"(, "transform": {"rotate": [90, 0, 0, 0]})"),
                 "volumes[0].transform.rotate: the rotation axis must be a non-zero vector");
}

TEST(SceneErrors, RenderRanges)
{
    EXPECT_ERROR(R"({"render": {"spp": -1}})", "render.spp: must be at least 0, got -1");
    EXPECT_ERROR(R"({"render": {"step": 0}})", "render.step: must be in [0.001, 100] voxels, got 0");
    EXPECT_ERROR(R"({"render": {"step": 1e-9}})", "render.step: must be in [0.001, 100] voxels, got 1e-09");
    EXPECT_ERROR(R"({"render": {"step": 101}})", "render.step: must be in [0.001, 100]");
    EXPECT_ERROR(R"({"render": {"shadow_map_resolution": 4}})", "render.shadow_map_resolution: must be in [8, 16384]");
    EXPECT_ERROR(R"({"render": {"shadow_map_resolution": 20000}})", "render.shadow_map_resolution: must be in");
    EXPECT_ERROR(R"({"render": {"tolerance": 0}})", "render.tolerance: must be in (0, 0.5]");
    EXPECT_ERROR(R"({"render": {"tolerance": 0.6}})", "render.tolerance: must be in (0, 0.5]");
    EXPECT_ERROR(R"({"render": {"threads": -1}})", "render.threads: must be at least 0, got -1");
    EXPECT_ERROR(R"({"render": {"max_depth": -1}})", "render.max_depth: must be at least 0");
    EXPECT_ERROR(R"({"render": {"light_samples": 0}})", "render.light_samples: must be at least 1");
    EXPECT_ERROR(R"({"render": {"shadow_step": 0}})", "render.shadow_step: must be in (0, 100]");
    EXPECT_ERROR(R"({"render": {"time_limit": -1}})", "render.time_limit: must be in [0, inf) seconds");
    EXPECT_ERROR(R"({"render": {"noise_target": -1e-4}})", "render.noise_target: must be in [0, 1] relMSE");
    EXPECT_ERROR(R"({"render": {"vrl_paths": 0}})", "render.vrl_paths: must be in [1, 4096]");
    EXPECT_ERROR(R"({"render": {"vrl_sampling": "uniform"}})",
                 "render.vrl_sampling: unknown VRL joint distribution 'uniform' (expected auto, simple, advanced)");
    EXPECT_ERROR(R"({"output": {"aovs": ["L0", "L0"]}})", "output.aovs[1]: 'L0' is listed twice");
    EXPECT_ERROR(R"({"background": -1})", "background: must be non-negative");
}

TEST(SceneErrors, NumbersBeyondFloatRange)
{
    // JSON has no NaN or infinity literals; a number too large for a float is where they come from.
    EXPECT_ERROR(R"({"camera": {"fov": 1e39}})", "camera.fov: out of range for a 32-bit float");
    EXPECT_ERROR(light(R"("type": "point", "intensity": [1, 1e300, 1])"), "lights[0].intensity[1]: out of range");
    EXPECT_ERROR(R"({"render": {"spp": 1e12}})", "render.spp: must be an integer in");
}

TEST(SceneErrors, PathTracerWithoutSppNeedsANoiseTargetOrATimeLimit)
{
    // spp 0 is the default: the path tracer then stops at the noise target or the time limit
    // (docs/pathtracer.md), and needs one of them.
    for (const char* ok : {R"({"render": {"method": "pathtrace"}})",
                           R"({"render": {"method": "pathtrace", "spp": 0, "noise_target": 0, "time_limit": 5}})",
                           R"({"render": {"method": "single", "spp": 0}})"})
        EXPECT_NO_THROW(sceneFromJson(json::parse(ok), "scene.json")) << ok;
    EXPECT_ERROR(R"({"render": {"method": "pathtrace", "noise_target": 0}})",
                 "render.noise_target: pathtrace with spp 0 needs a noise_target or a time_limit");
    EXPECT_ERROR(R"({"render": {"method": "vrl", "noise_target": 0}})",
                 "render.noise_target: vrl with spp 0 needs a noise_target or a time_limit");
}

TEST(SceneErrors, EmptySceneIsValid)
{
    EXPECT_NO_THROW(sceneFromJson(json::parse(R"({"lights": [], "volumes": []})"), "scene.json"));
}

// Failure 8 of issue 18: duplicate keys were accepted silently (the last won).
TEST(SceneErrors, DuplicateKeysAreAnErrorNamingTheKeyPath)
{
    auto duplicateError = [](const std::string& text) {
        try {
            parseJsonRejectingDuplicateKeys(text, "scene.json");
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_EQ(duplicateError(R"({"camera": {"fov": 30, "fov": 40}})"),
              "scene.json: camera.fov: duplicate key (each key may appear once in an object)");
    EXPECT_NE(duplicateError(R"({"volumes": [{"name": "a"}, {"medium": {"sigma_s": 1, "sigma_s": 2}}]})")
                  .find("scene.json: volumes[1].medium.sigma_s: duplicate key"),
              std::string::npos);
    EXPECT_NE(
        duplicateError(R"({"lights": [[1, 2], {"a": 1}, {"b": [0, {"c": 1, "c": 2}]}]})").find("lights[2].b[1].c:"),
        std::string::npos);
    EXPECT_NE(duplicateError(R"({"render": {}, "render": {}})").find("scene.json: render: duplicate key"),
              std::string::npos);
    // The same key in different objects is fine, and the document parses as parse() would.
    EXPECT_EQ(duplicateError(R"({"a": {"x": 1}, "b": {"x": 1}, "c": [{"x": 1}, {"x": 2}]})"), "");
    EXPECT_EQ(parseJsonRejectingDuplicateKeys(R"({"a": [1, {"b": 2}]})", "f"), json::parse(R"({"a": [1, {"b": 2}]})"));
}

// Failure 8: /dev/zero as a scene was read until memory ran out. Only a regular file of at most
// 64 MiB is read; the others are refused from stat() alone.
TEST(SceneErrors, SceneFileMustBeARegularFileOfSaneSize)
{
    const std::string dir = std::filesystem::temp_directory_path() / ("nimbus-scene-" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    const std::string fifo = dir + "/pipe.json", big = dir + "/big.json";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
    std::ofstream(big) << "{}";
    std::filesystem::resize_file(big, kMaxSceneFileBytes + 1);  // sparse
    for (const std::string& path : {std::string("/dev/zero"), fifo, big, dir}) {
        try {
            readJsonFile(path);
            ADD_FAILURE() << path << " was read";
        } catch (const InputError& e) {
            const std::string what = e.what();
            EXPECT_EQ(what.rfind(path + ": cannot open scene file", 0), 0u) << what;
        }
    }
    std::filesystem::remove_all(dir);
}
