// Renders at the edges of the input ranges (issue 18, "every input range renders or errors
// clearly"): each either finishes with a finite film or throws InputError, one line naming the
// key. A render that hangs fails by the deadline instead of hanging the suite.
#include "../render/SceneBuilders.h"

#include "core/Error.h"
#include "engine/Renderer.h"
#include "scene/SceneValidate.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <future>
#include <string>
#include <thread>

using namespace nimbus;
using namespace nimbus::test;

namespace {

const char* const kMethods[] = {"single", "wkb"};

Method methodOf(const std::string& name)
{
    return name == "wkb" ? Method::Wkb : Method::Single;
}

// A small lit cloud with the given medium scale.
Scene cloudScene(Method method, float densityScale)
{
    Scene s = emptyScene(24, 16);
    s.camera.from = make_float3(0, 0.5f, 6);
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 35;
    s.render.method = method;
    s.render.spp = 1;
    s.render.shadowMapResolution = 32;
    s.volumes.push_back(proceduralCloud(0.08, splat(2.5f), splat(0.025f), 0.6f));
    s.volumes[0].medium.densityScale = densityScale;
    s.lights.push_back(distantLight("key", make_float3(1, -1, -0.7f), splat(3.0f)));
    return s;
}

// Renders on another thread; a render still running after `seconds` is a hang: the test fails
// and the process exits (the render thread cannot be stopped from outside).
RenderResult renderWithin(const Scene& scene, double seconds)
{
    auto future = std::async(std::launch::async, [scene] { return render(scene); });
    if (future.wait_for(std::chrono::duration<double>(seconds)) != std::future_status::ready) {
        ADD_FAILURE() << methodName(scene.render.method) << " render still running after " << seconds << " s";
        std::fflush(stdout);
        std::_Exit(1);
    }
    return future.get();
}

size_t nonFinite(const Film& film)
{
    size_t n = 0;
    for (const Aov& aov : film.aovs)
        for (float v : aov.pixels)
            n += !std::isfinite(v);
    return n;
}

}  // namespace

// Failure 3: sigma_s = density_scale = 1e30 hung wkb (the l-march's step became 0) and gave
// single an all-NaN image with exit 0. Now an input error naming the key, before any work.
TEST(InputExtremes, ExtinctionOverflowIsAnInputErrorNamingTheKey)
{
    for (const char* method : kMethods) {
        Scene s = cloudScene(methodOf(method), 1e30f);
        s.volumes[0].medium.sigma_s = splat(1e30f);
        try {
            renderWithin(s, 60);
            ADD_FAILURE() << method << ": rendered an extinction of 1e60 1/m";
        } catch (const InputError& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find("volumes[0].medium.density_scale"), std::string::npos) << what;
            EXPECT_EQ(what.find('\n'), std::string::npos) << what;
        }
    }
}

// The voxels' share: the medium is within range at density 1, but voxels of 1e30 (1e38 in a VDB
// file gave NaN pixels without a warning: tests/cli) are caught once the grid is loaded.
TEST(InputExtremes, DenseVoxelsBeyondTheRangeAreAnInputError)
{
    Scene s = cloudScene(Method::Single, 1.0f);
    s.volumes[0].source.params["density"] = 1e30;
    s.volumes[0].medium.sigma_s = splat(1.5f);
    EXPECT_NO_THROW(validateScene(s));
    try {
        renderWithin(s, 60);
        ADD_FAILURE() << "rendered voxels beyond the extinction range";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("volumes[0].medium.density_scale"), std::string::npos) << e.what();
    }
}

// Just inside the range both marchers finish promptly with a finite film: the l-march's step
// never becomes 0 and non-finite samples never reach the film.
TEST(InputExtremes, ExtinctionAtTheTopOfTheRangeRendersFiniteAndPromptly)
{
    for (const char* method : kMethods)
        for (float scale : {1e20f, 3e29f}) {
            const RenderResult r = renderWithin(cloudScene(methodOf(method), scale), 120);
            EXPECT_EQ(nonFinite(r.film), 0u) << method << " at density_scale " << scale;
        }
}

// A light of 3e38 W/m^2 overflows float in the marchers: those values are set to 0 (with one
// warning), never written as NaN or inf.
TEST(InputExtremes, NonFiniteSamplesNeverReachTheFilm)
{
    for (const char* method : kMethods) {
        Scene s = cloudScene(methodOf(method), 1.0f);
        s.lights[0].irradiance = splat(3e38f);
        const RenderResult r = renderWithin(s, 120);
        EXPECT_EQ(nonFinite(r.film), 0u) << method;
    }
}

// Failure 4: SIGSEGV at fov 1e-10 (an int overflow in tile culling). Tiny fields of view on
// ordinary and extreme image shapes: each method finishes with a finite film or refuses the
// scene with an InputError. The path tracer runs where an OpenCL device exists.
TEST(InputExtremes, TinyFieldsOfViewRenderFinite)
{
    struct Shape {
        int w, h;
    };
    for (const char* method : {"single", "wkb", "pathtrace"})
        for (float fov : {1e-10f, 1e-30f})
            for (Shape shape : {Shape{24, 16}, Shape{65536, 1}, Shape{1, 65536}}) {
                Scene s = cloudScene(method == std::string("pathtrace") ? Method::Pathtrace : methodOf(method), 1.0f);
                s.camera.fov = fov;
                s.camera.width = shape.w;
                s.camera.height = shape.h;
                s.render.maxDepth = 2;
                try {
                    const RenderResult r = renderWithin(s, 300);
                    EXPECT_EQ(nonFinite(r.film), 0u) << method << " fov " << fov << " " << shape.w << "x" << shape.h;
                } catch (const InputError& e) {
                    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
                } catch (const Error& e) {
                    if (std::string(method) == "pathtrace" && std::string(e.what()).find("OpenCL") != std::string::npos)
                        continue;  // no device on this machine: the other two still ran
                    ADD_FAILURE() << method << " fov " << fov << ": " << e.what();
                }
            }
}

// Below 1e-30 degrees tan(fov / 2) is no longer a normal float and every ray would be the same:
// the documented range's lower end (docs/scene-format.md).
TEST(InputExtremes, FieldOfViewBelowTheRangeIsAnInputError)
{
    Scene s = cloudScene(Method::Single, 1.0f);
    s.camera.fov = 1e-40f;
    try {
        validateScene(s);
        ADD_FAILURE() << "fov 1e-40 accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("camera.fov"), std::string::npos) << e.what();
    }
}
