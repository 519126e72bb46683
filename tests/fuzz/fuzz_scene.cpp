// fuzz_scene: the scene file and the CLI's --set overrides, parsed and validated as
// `nimbus render` does before it loads anything (issue 18, item 5). Nothing is rendered or read
// besides the scene file.
//
// Input: the scene document, then optionally a NUL byte and NUL-separated --set assignments
// ("camera.fov=1e-10"). An empty document stands for --default (the embedded default scene as
// JSON, the overrides applied to it). For each input:
//
//   loadSceneFile (readJsonFile, applyOverrides, sceneFromJson), then, as runRender does, the
//   scene at its render.frame (sceneAtFrame: animation keys and frame tokens) and validateScene;
//   and the format's round trip (SceneJson.h: sceneFromJson(sceneToJson(s)) equals s): the
//   scene written back must read again, to the same document.
//
// Only InputError may come out (FuzzSupport.h). Corpus: tests/fuzz/corpus/scene (the docs'
// examples and the default scene, each with a few overrides).
#include "FuzzSupport.h"

#include "scene/DefaultScene.h"
#include "scene/FrameTokens.h"
#include "scene/SceneJson.h"
#include "scene/SceneValidate.h"

#include <nlohmann/json.hpp>

#include <cstring>
#include <string>
#include <vector>

using namespace nimbus;

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    fuzz::quietLogs();
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    const uint8_t* end = data + size;
    const uint8_t* nul = static_cast<const uint8_t*>(std::memchr(data, 0, size));
    const size_t documentBytes = nul ? size_t(nul - data) : size;
    std::vector<std::string> overrides;
    for (const uint8_t* p = nul; p && p < end;) {
        const uint8_t* next = static_cast<const uint8_t*>(std::memchr(p + 1, 0, size_t(end - p - 1)));
        const uint8_t* stop = next ? next : end;
        overrides.emplace_back(reinterpret_cast<const char*>(p + 1), size_t(stop - p - 1));
        p = next;
    }

    fuzz::expectOnlyInputErrors([&] {
        Scene scene;
        if (documentBytes == 0) {
            nlohmann::json j = sceneToJson(defaultScene());
            applyOverrides(j, overrides, "default scene");
            scene = sceneFromJson(j, "");
        } else {
            const std::string path = fuzz::writeInput(data, documentBytes, ".json");
            scene = loadSceneFile(path, overrides);
        }
        const Scene frame = sceneAtFrame(scene, scene.render.frame);
        validateScene(frame);

        const nlohmann::json written = sceneToJson(scene);
        Scene reread;
        try {
            reread = sceneFromJson(written, scene.sourcePath);
        } catch (const InputError& e) {
            fuzz::finding(std::string("a scene that read does not read again once written: ") + e.what() + "\n" +
                          written.dump());
        }
        const nlohmann::json rewritten = sceneToJson(reread);
        if (rewritten != written)
            fuzz::finding("the scene written, read and written again differs:\n" + written.dump() + "\n" +
                          rewritten.dump());
    });
    return 0;
}
