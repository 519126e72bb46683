// ApiObjects.h: the scene-side objects behind C ABI handles: cameras, lights, volumes, scenes.
//
// Parameters are declared once, in the scene format's reader (SceneJson.cpp, SceneValidate.cpp):
// each object keeps its own JSON object of the format, a parameter set by name writes one key
// of it, and the edited object is read back by sceneFromJson at once, alone in a scene of its
// own. So the API accepts exactly the names, types and ranges a scene file accepts and reports
// them in the same words; the C ABI has no parameter table to drift from the format's.
// nimbus_commit assembles the objects into one document and reads it as `nimbus render` would.
#pragma once

#include "HandleRegistry.h"

#include "../scene/Scene.h"

#include <nlohmann/json.hpp>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace nimbus::api {

// One object of the scene format, edited key by key.
class ParamObject : public ApiObject {
public:
    using ApiObject::ApiObject;

    // name: a key path with dots ("medium.phase.g"). Throws ApiError / InputError and leaves the
    // object unchanged when the edited object does not read back.
    void set(const std::string& name, nlohmann::json value);
    void unset(const std::string& name);
    void validate() const;
    nlohmann::json document() const;

    // Replaces the whole object (loading); not validated here.
    void assign(nlohmann::json document);

protected:
    // The edited object inside a scene document that sceneFromJson can read alone, with
    // stand-ins for what is checked only at commit (a vdb volume's file).
    virtual nlohmann::json wrap(const nlohmann::json& object) const = 0;
    // The key path of the wrapped object in messages ("lights[0]") and what to say instead.
    virtual std::string wrappedPath() const = 0;
    virtual std::string label() const = 0;
    // Names this object refuses before any reading (a scene's "camera": use the camera handle).
    virtual void checkName(const std::string& name) const {}

private:
    void check(const nlohmann::json& candidate) const;

    mutable std::mutex mMutex;
    nlohmann::json mDocument = nlohmann::json::object();
};

class CameraObject : public ParamObject {
public:
    CameraObject() : ParamObject(NIMBUS_TYPE_CAMERA) {}

protected:
    nlohmann::json wrap(const nlohmann::json& object) const override;
    std::string wrappedPath() const override { return "camera"; }
    std::string label() const override { return "camera"; }
};

class LightObject : public ParamObject {
public:
    LightObject() : ParamObject(NIMBUS_TYPE_LIGHT) {}

protected:
    nlohmann::json wrap(const nlohmann::json& object) const override;
    std::string wrappedPath() const override { return "lights[0]"; }
    std::string label() const override { return "light"; }
};

class VolumeObject : public ParamObject {
public:
    VolumeObject() : ParamObject(NIMBUS_TYPE_VOLUME) {}

protected:
    nlohmann::json wrap(const nlohmann::json& object) const override;
    std::string wrappedPath() const override { return "volumes[0]"; }
    std::string label() const override { return "volume"; }
};

// A scene: its own keys (render, output, background) and the objects attached to it.
class SceneObject : public ParamObject {
public:
    SceneObject();

    // Loads a document read from a file (sourcePath) or built in memory: validates it, splits
    // it into objects and commits.
    void load(const nlohmann::json& document, const std::string& sourcePath);

    void setCamera(std::shared_ptr<CameraObject> camera);
    std::shared_ptr<CameraObject> camera() const;
    void addLight(std::shared_ptr<LightObject> light);
    void removeLight(const std::shared_ptr<LightObject>& light);
    std::vector<std::shared_ptr<LightObject>> lights() const;
    void addVolume(std::shared_ptr<VolumeObject> volume);
    void removeVolume(const std::shared_ptr<VolumeObject>& volume);
    std::vector<std::shared_ptr<VolumeObject>> volumes() const;

    // Reads the assembled document (every object's current values) and makes it the snapshot.
    void commit();
    // The last committed scene; throws ApiError NOT_COMMITTED if there is none.
    std::shared_ptr<const Scene> committed() const;

protected:
    nlohmann::json wrap(const nlohmann::json& object) const override { return object; }
    std::string wrappedPath() const override { return ""; }
    std::string label() const override { return "scene"; }
    void checkName(const std::string& name) const override;

private:
    mutable std::mutex mObjectsMutex;  // the lists, the source path and the snapshot
    std::shared_ptr<CameraObject> mCamera;
    std::vector<std::shared_ptr<LightObject>> mLights;
    std::vector<std::shared_ptr<VolumeObject>> mVolumes;
    std::string mSourcePath;  // anchors relative vdb paths, prefixes messages
    std::shared_ptr<const Scene> mCommitted;
};

}  // namespace nimbus::api
