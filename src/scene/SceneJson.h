// SceneJson.h: the JSON scene format (docs/scene-format.md), read into and written from Scene.
//
// The loader is one client of the Scene API (DESIGN "data flow"): it builds a Scene and hands it
// to validateScene, so a file and an API client meet the same checks. Every error is an
// InputError of one line, "<file>: <key.path>: <what>". Writing is the exact inverse of reading
// (Tungsten's rule): sceneFromJson(sceneToJson(s)) equals s in every field the scene uses.
#pragma once

#include "Scene.h"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace nimbus {

// The format version this build reads and writes (the optional top-level "version" key).
constexpr int kSceneFormatVersion = 1;

// The largest scene file read: 64 MiB, far beyond any scene (grids live in VDB files).
constexpr uint64_t kMaxSceneFileBytes = uint64_t(64) << 20;

// Reads and parses a JSON file: a regular file of at most kMaxSceneFileBytes (anything else is
// refused before it is read), each key once per object (a duplicate throws InputError naming its
// key path). Throws InputError "path: cannot open scene file: <reason>" or
// "path: invalid JSON at line L, column C: <message>".
nlohmann::json readJsonFile(const std::string& path);

// Applies the CLI's "--set key.path=value" assignments to a scene document, in order. The path
// uses dots for object keys and [i] for list entries (lights[0].irradiance); missing objects on
// the way are created, list entries must exist. The value is parsed as JSON if it parses (16,
// [320,180], true) and taken as a string otherwise (wkb, out/a.exr). A malformed assignment
// throws InputError "<sourcePath>: --set '<assignment>': <what>". Values are not checked here:
// sceneFromJson checks them like any other value in the file.
void applyOverrides(nlohmann::json& scene, const std::vector<std::string>& overrides, const std::string& sourcePath);

// Builds and validates a Scene from a parsed document. sourcePath names the file in messages
// and anchors relative vdb "file" paths (resolved against its directory); empty: a document
// built in memory, paths kept as written.
Scene sceneFromJson(const nlohmann::json& document, const std::string& sourcePath = "");

// readJsonFile, applyOverrides, sceneFromJson.
Scene loadSceneFile(const std::string& path, const std::vector<std::string>& overrides = {});

// The complete document for a scene: every key with its value, defaults included, so that a
// written scene records exactly what was rendered.
nlohmann::json sceneToJson(const Scene& scene);

}  // namespace nimbus
