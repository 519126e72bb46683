#include "ApiObjects.h"

#include "ApiError.h"

#include "../core/Error.h"
#include "../scene/SceneJson.h"

#include <algorithm>

namespace nimbus::api {

using nlohmann::json;

namespace {

// "medium.phase.g" -> {"medium", "phase", "g"}. List entries are objects of their own (a
// scene's lights are light handles), so there is no [i] here.
std::vector<std::string> splitName(const std::string& name)
{
    if (name.empty())
        throw ApiError(NIMBUS_ERROR_UNKNOWN_PARAMETER, "empty parameter name");
    if (name.find_first_of("[]") != std::string::npos)
        throw ApiError(NIMBUS_ERROR_UNKNOWN_PARAMETER,
                       "'" + name + "': list entries are objects of their own (use their handles)");
    std::vector<std::string> keys;
    size_t start = 0;
    while (true) {
        size_t dot = name.find('.', start);
        std::string key = name.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
        if (key.empty())
            throw ApiError(NIMBUS_ERROR_UNKNOWN_PARAMETER, "'" + name + "': empty key between dots");
        keys.push_back(key);
        if (dot == std::string::npos)
            return keys;
        start = dot + 1;
    }
}

}  // namespace

NimbusStatus classifyInputError(const std::string& message)
{
    if (message.find(": unknown key") != std::string::npos)
        return NIMBUS_ERROR_UNKNOWN_PARAMETER;
    if (message.find(": expected ") != std::string::npos && message.find(", got ") != std::string::npos)
        return NIMBUS_ERROR_WRONG_TYPE;
    return NIMBUS_ERROR_BAD_INPUT;
}

// ---- ParamObject ---------------------------------------------------------------------------

void ParamObject::check(const json& candidate) const
{
    try {
        sceneFromJson(wrap(candidate), "");
    } catch (const InputError& e) {
        std::string message = e.what();
        // "lights[0].cone_angle: ..." -> "light.cone_angle: ...": the object is not in a list yet.
        const std::string path = wrappedPath();
        if (!path.empty() && message.compare(0, path.size(), path) == 0)
            message = label() + message.substr(path.size());
        throw ApiError(classifyInputError(message), message);
    }
}

void ParamObject::set(const std::string& name, json value)
{
    checkName(name);
    const std::vector<std::string> keys = splitName(name);
    std::lock_guard<std::mutex> lock(mMutex);
    json candidate = mDocument;
    json* node = &candidate;
    for (size_t i = 0; i + 1 < keys.size(); ++i) {
        json& next = (*node)[keys[i]];
        // A key that held a value of another shape takes the object form ("transform" given
        // as a matrix, then "transform.scale"): the reader then checks the new form.
        if (!next.is_object())
            next = json::object();
        node = &next;
    }
    (*node)[keys.back()] = std::move(value);
    check(candidate);
    mDocument = std::move(candidate);
}

void ParamObject::unset(const std::string& name)
{
    checkName(name);
    const std::vector<std::string> keys = splitName(name);
    std::lock_guard<std::mutex> lock(mMutex);
    json candidate = mDocument;
    json* node = &candidate;
    for (size_t i = 0; i + 1 < keys.size(); ++i) {
        auto it = node->find(keys[i]);
        if (it == node->end() || !it->is_object())
            return;  // absent already
        node = &*it;
    }
    if (!node->contains(keys.back()))
        return;
    node->erase(keys.back());
    check(candidate);  // e.g. a light's "type" is required
    mDocument = std::move(candidate);
}

void ParamObject::validate() const
{
    std::lock_guard<std::mutex> lock(mMutex);
    check(mDocument);
}

json ParamObject::document() const
{
    std::lock_guard<std::mutex> lock(mMutex);
    return mDocument;
}

void ParamObject::assign(json document)
{
    std::lock_guard<std::mutex> lock(mMutex);
    mDocument = std::move(document);
}

// ---- cameras, lights, volumes --------------------------------------------------------------

json CameraObject::wrap(const json& object) const
{
    return {{"camera", object}};
}

json LightObject::wrap(const json& object) const
{
    return {{"lights", json::array({object})}};
}

json VolumeObject::wrap(const json& object) const
{
    // A vdb file or plugin path not set yet is checked at commit (with the other objects), not
    // at every edit: stand-ins let the rest of the volume be read.
    json v = object;
    auto source = v.find("source");
    if (source != v.end() && source->is_object()) {
        auto type = source->find("type");
        if (type != source->end() && type->is_string()) {
            if (*type == "vdb" && !source->contains("file"))
                (*source)["file"] = "unset.vdb";
            if (*type == "plugin" && !source->contains("path"))
                (*source)["path"] = "unset.so";
        }
    }
    return {{"volumes", json::array({v})}};
}

// ---- SceneObject ---------------------------------------------------------------------------

SceneObject::SceneObject() : ParamObject(NIMBUS_TYPE_SCENE), mCamera(std::make_shared<CameraObject>()) {}

void SceneObject::checkName(const std::string& name) const
{
    const std::string first = name.substr(0, name.find_first_of(".["));
    if (first == "camera" || first == "lights" || first == "volumes")
        throw ApiError(NIMBUS_ERROR_UNKNOWN_PARAMETER,
                       "'" + name + "' is not a scene parameter: " + first +
                           " are objects of their own (nimbus_scene_get_camera, _get_light, _get_volume)");
}

void SceneObject::load(const json& document, const std::string& sourcePath)
{
    Scene scene = sceneFromJson(document, sourcePath);  // every check, with the file's key paths
    auto camera = std::make_shared<CameraObject>();
    std::vector<std::shared_ptr<LightObject>> lights;
    std::vector<std::shared_ptr<VolumeObject>> volumes;
    json own = document;
    if (auto it = own.find("camera"); it != own.end())
        camera->assign(*it);
    if (auto it = own.find("lights"); it != own.end())
        for (const json& l : *it) {
            lights.push_back(std::make_shared<LightObject>());
            lights.back()->assign(l);
        }
    if (auto it = own.find("volumes"); it != own.end())
        for (const json& v : *it) {
            volumes.push_back(std::make_shared<VolumeObject>());
            volumes.back()->assign(v);
        }
    for (const char* key : {"camera", "lights", "volumes"})
        own.erase(key);
    assign(std::move(own));
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    mCamera = std::move(camera);
    mLights = std::move(lights);
    mVolumes = std::move(volumes);
    mSourcePath = sourcePath;
    mCommitted = std::make_shared<const Scene>(std::move(scene));
}

void SceneObject::setCamera(std::shared_ptr<CameraObject> camera)
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    mCamera = std::move(camera);
}

std::shared_ptr<CameraObject> SceneObject::camera() const
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    return mCamera;
}

void SceneObject::addLight(std::shared_ptr<LightObject> light)
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    if (std::find(mLights.begin(), mLights.end(), light) != mLights.end())
        throw ApiError(NIMBUS_ERROR_INVALID_ARGUMENT, "the light is already in the scene");
    mLights.push_back(std::move(light));
}

void SceneObject::removeLight(const std::shared_ptr<LightObject>& light)
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    auto it = std::find(mLights.begin(), mLights.end(), light);
    if (it == mLights.end())
        throw ApiError(NIMBUS_ERROR_NOT_FOUND, "the light is not in the scene");
    mLights.erase(it);
}

std::vector<std::shared_ptr<LightObject>> SceneObject::lights() const
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    return mLights;
}

void SceneObject::addVolume(std::shared_ptr<VolumeObject> volume)
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    if (std::find(mVolumes.begin(), mVolumes.end(), volume) != mVolumes.end())
        throw ApiError(NIMBUS_ERROR_INVALID_ARGUMENT, "the volume is already in the scene");
    mVolumes.push_back(std::move(volume));
}

void SceneObject::removeVolume(const std::shared_ptr<VolumeObject>& volume)
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    auto it = std::find(mVolumes.begin(), mVolumes.end(), volume);
    if (it == mVolumes.end())
        throw ApiError(NIMBUS_ERROR_NOT_FOUND, "the volume is not in the scene");
    mVolumes.erase(it);
}

std::vector<std::shared_ptr<VolumeObject>> SceneObject::volumes() const
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    return mVolumes;
}

void SceneObject::commit()
{
    json doc = document();
    std::string sourcePath;
    {
        std::lock_guard<std::mutex> lock(mObjectsMutex);
        doc["camera"] = mCamera->document();
        doc["lights"] = json::array();
        for (const auto& l : mLights)
            doc["lights"].push_back(l->document());
        doc["volumes"] = json::array();
        for (const auto& v : mVolumes)
            doc["volumes"].push_back(v->document());
        sourcePath = mSourcePath;
    }
    auto scene = std::make_shared<const Scene>(sceneFromJson(doc, sourcePath));
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    mCommitted = std::move(scene);
}

std::shared_ptr<const Scene> SceneObject::committed() const
{
    std::lock_guard<std::mutex> lock(mObjectsMutex);
    if (!mCommitted)
        throw ApiError(NIMBUS_ERROR_NOT_COMMITTED, "the scene has not been committed");
    return mCommitted;
}

}  // namespace nimbus::api
