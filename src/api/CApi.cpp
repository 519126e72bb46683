// CApi.cpp: the extern "C" entry points of nimbus.h.
//
// Each one is a guard around C++: arguments are checked, handles resolved through the
// registry, and every exception (ours, the renderer's, the standard library's, anything) is
// caught here and becomes a NimbusStatus plus the thread's last-error message. Nothing else
// in the library knows it is being called from C.
#include "nimbus.h"

#include "ApiError.h"
#include "ApiObjects.h"
#include "ApiSession.h"
#include "HandleRegistry.h"

#include "../core/Error.h"
#include "../core/OneLine.h"
#include "../core/Utf8.h"
#include "../engine/Renderer.h"
#include "../io/Outputs.h"
#include "../scene/SceneJson.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

using namespace nimbus;
using namespace nimbus::api;
using nlohmann::json;

namespace {

thread_local std::string tLastError;

NimbusStatus fail(NimbusStatus status, const std::string& message)
{
    try {
        tLastError = oneLine(message);
    } catch (...) {
        tLastError.clear();
    }
    return status;
}

template <class F>
NimbusStatus guard(F&& body) noexcept
{
    tLastError.clear();
    try {
        return body();
    } catch (const ApiError& e) {
        return fail(e.status(), e.what());
    } catch (const Cancelled& e) {
        return fail(NIMBUS_ERROR_CANCELLED, e.what());
    } catch (const InputError& e) {
        return fail(classifyInputError(e.what()), e.what());
    } catch (const Error& e) {
        return fail(NIMBUS_ERROR_RENDER_FAILED, e.what());
    } catch (const std::bad_alloc&) {
        return fail(NIMBUS_ERROR_OUT_OF_MEMORY, "out of memory");
    } catch (const std::exception& e) {
        return fail(NIMBUS_ERROR_INTERNAL, std::string("internal error: ") + e.what());
    } catch (...) {
        return fail(NIMBUS_ERROR_INTERNAL, "internal error: unknown exception");
    }
}

template <class T>
T* required(T* p, const char* what)
{
    if (!p)
        throw ApiError(NIMBUS_ERROR_INVALID_ARGUMENT, std::string(what) + " is NULL");
    return p;
}

const char* requiredString(const char* s, const char* what)
{
    return required(s, what);
}

// A string value of the scene format (JSON): UTF-8 text, or NIMBUS_ERROR_WRONG_TYPE naming the key.
std::string textValue(const char* s, const char* what, const char* key)
{
    const std::string v = requiredString(s, what);
    const size_t bad = firstInvalidUtf8(v);
    if (bad < v.size()) {
        char byte[8];
        std::snprintf(byte, sizeof byte, "0x%02X", unsigned(static_cast<unsigned char>(v[bad])));
        throw ApiError(NIMBUS_ERROR_WRONG_TYPE, std::string(key ? key : "") + ": not UTF-8 text (byte " + byte +
                                                    " at offset " + std::to_string(bad) +
                                                    "; the scene format is JSON, whose strings are UTF-8)");
    }
    return v;
}

HandleRegistry& registry()
{
    return HandleRegistry::instance();
}

std::shared_ptr<SceneObject> sceneOf(NimbusHandle h)
{
    return registry().get<SceneObject>(h, NIMBUS_TYPE_SCENE);
}
std::shared_ptr<SessionObject> sessionOf(NimbusHandle h)
{
    return registry().get<SessionObject>(h, NIMBUS_TYPE_SESSION);
}
std::shared_ptr<FrameObject> frameOf(NimbusHandle h)
{
    return registry().get<FrameObject>(h, NIMBUS_TYPE_FRAME);
}

// Scenes, cameras, lights and volumes take parameters; sessions and frames do not.
std::shared_ptr<ParamObject> paramsOf(NimbusHandle h)
{
    std::shared_ptr<ApiObject> o = registry().get(h);
    switch (o->type()) {
    case NIMBUS_TYPE_SCENE:
    case NIMBUS_TYPE_CAMERA:
    case NIMBUS_TYPE_LIGHT:
    case NIMBUS_TYPE_VOLUME: return std::static_pointer_cast<ParamObject>(o);
    default:
        throw ApiError(NIMBUS_ERROR_WRONG_HANDLE_TYPE, std::string("wrong handle type: a ") +
                                                           handleTypeName(o->type()) +
                                                           " has no parameters (scenes, cameras, lights and "
                                                           "volumes have)");
    }
}

NimbusStatus setParam(NimbusHandle h, const char* name, json value)
{
    return guard([&] {
        requiredString(name, "name");
        paramsOf(h)->set(name, std::move(value));
        return NIMBUS_OK;
    });
}

template <class T>
NimbusStatus returnHandle(std::shared_ptr<T> object, NimbusHandle* out)
{
    *out = registry().add(std::move(object));
    return NIMBUS_OK;
}

void fillAov(const FrameObject& frame, const Aov& a, NimbusAov* out)
{
    const Film& film = frame.result().film;
    out->name = a.name.c_str();
    out->pixels = a.pixels.data();
    out->width = film.width;
    out->height = film.height;
    out->channels = a.channels;
    out->is_data = a.isData ? 1 : 0;
    out->x0 = film.x0, out->y0 = film.y0, out->x1 = film.x1, out->y1 = film.y1;
}

}  // namespace

extern "C" {

// ---- library --------------------------------------------------------------------------------

const char* nimbus_version(void)
{
    return NIMBUS_VERSION;
}

int nimbus_abi_version(void)
{
    return NIMBUS_ABI_VERSION;
}

const char* nimbus_last_error(void)
{
    return tLastError.c_str();
}

const char* nimbus_status_name(NimbusStatus status)
{
    switch (status) {
    case NIMBUS_OK: return "NIMBUS_OK";
    case NIMBUS_ERROR_INVALID_ARGUMENT: return "NIMBUS_ERROR_INVALID_ARGUMENT";
    case NIMBUS_ERROR_INVALID_HANDLE: return "NIMBUS_ERROR_INVALID_HANDLE";
    case NIMBUS_ERROR_WRONG_HANDLE_TYPE: return "NIMBUS_ERROR_WRONG_HANDLE_TYPE";
    case NIMBUS_ERROR_UNKNOWN_PARAMETER: return "NIMBUS_ERROR_UNKNOWN_PARAMETER";
    case NIMBUS_ERROR_WRONG_TYPE: return "NIMBUS_ERROR_WRONG_TYPE";
    case NIMBUS_ERROR_BAD_INPUT: return "NIMBUS_ERROR_BAD_INPUT";
    case NIMBUS_ERROR_NOT_COMMITTED: return "NIMBUS_ERROR_NOT_COMMITTED";
    case NIMBUS_ERROR_BUSY: return "NIMBUS_ERROR_BUSY";
    case NIMBUS_ERROR_CANCELLED: return "NIMBUS_ERROR_CANCELLED";
    case NIMBUS_ERROR_TIMEOUT: return "NIMBUS_ERROR_TIMEOUT";
    case NIMBUS_ERROR_NOT_FOUND: return "NIMBUS_ERROR_NOT_FOUND";
    case NIMBUS_ERROR_RENDER_FAILED: return "NIMBUS_ERROR_RENDER_FAILED";
    case NIMBUS_ERROR_OUT_OF_MEMORY: return "NIMBUS_ERROR_OUT_OF_MEMORY";
    case NIMBUS_ERROR_BUFFER_TOO_SMALL: return "NIMBUS_ERROR_BUFFER_TOO_SMALL";
    case NIMBUS_ERROR_INTERNAL: return "NIMBUS_ERROR_INTERNAL";
    }
    return "unknown status";
}

// ---- handles --------------------------------------------------------------------------------

NimbusStatus nimbus_retain(NimbusHandle handle)
{
    return guard([&] {
        registry().retain(handle);
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_release(NimbusHandle handle)
{
    return guard([&] {
        registry().release(handle);
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_handle_type(NimbusHandle handle, NimbusHandleType* type)
{
    return guard([&] {
        *required(type, "type") = registry().get(handle)->type();
        return NIMBUS_OK;
    });
}

// ---- parameters -----------------------------------------------------------------------------

NimbusStatus nimbus_set_int(NimbusHandle object, const char* name, int64_t value)
{
    return setParam(object, name, json(value));
}

NimbusStatus nimbus_set_float(NimbusHandle object, const char* name, double value)
{
    return setParam(object, name, json(value));
}

NimbusStatus nimbus_set_float3(NimbusHandle object, const char* name, double x, double y, double z)
{
    return setParam(object, name, json::array({x, y, z}));
}

NimbusStatus nimbus_set_floats(NimbusHandle object, const char* name, const double* values, size_t count)
{
    return guard([&] {
        if (count > 0)
            required(values, "values");
        json a = json::array();
        for (size_t i = 0; i < count; ++i)
            a.push_back(values[i]);
        return setParam(object, name, std::move(a));
    });
}

NimbusStatus nimbus_set_string(NimbusHandle object, const char* name, const char* value)
{
    return guard([&] { return setParam(object, name, json(textValue(value, "value", name))); });
}

NimbusStatus nimbus_set_strings(NimbusHandle object, const char* name, const char* const* values, size_t count)
{
    return guard([&] {
        if (count > 0)
            required(values, "values");
        json a = json::array();
        for (size_t i = 0; i < count; ++i)
            a.push_back(textValue(values[i], "values[i]", name));
        return setParam(object, name, std::move(a));
    });
}

NimbusStatus nimbus_set_json(NimbusHandle object, const char* name, const char* text)
{
    return guard([&] {
        json value;
        try {
            value = json::parse(requiredString(text, "json"));
        } catch (const json::exception& e) {
            throw ApiError(NIMBUS_ERROR_WRONG_TYPE,
                           std::string(name ? name : "") + ": invalid JSON value: " + e.what());
        }
        return setParam(object, name, std::move(value));
    });
}

NimbusStatus nimbus_unset(NimbusHandle object, const char* name)
{
    return guard([&] {
        paramsOf(object)->unset(requiredString(name, "name"));
        return NIMBUS_OK;
    });
}

// ---- scenes ---------------------------------------------------------------------------------

NimbusStatus nimbus_scene_create(NimbusScene* scene)
{
    return guard([&] { return returnHandle(std::make_shared<SceneObject>(), required(scene, "scene")); });
}

NimbusStatus nimbus_scene_load_file(const char* path, NimbusScene* scene)
{
    return guard([&] {
        required(scene, "scene");
        const std::string file = requiredString(path, "path");
        auto object = std::make_shared<SceneObject>();
        object->load(readJsonFile(file), file);
        return returnHandle(std::move(object), scene);
    });
}

NimbusStatus nimbus_scene_load_json(const char* text, const char* basePath, NimbusScene* scene)
{
    return guard([&] {
        required(scene, "scene");
        json document;
        try {
            document = json::parse(requiredString(text, "json"));
        } catch (const json::exception& e) {
            throw ApiError(NIMBUS_ERROR_BAD_INPUT, std::string("invalid JSON: ") + e.what());
        }
        // The loader anchors relative paths at the directory of its source path: a directory
        // given here is that directory (a trailing separator makes it its own parent).
        std::string source;
        if (basePath && *basePath)
            source = (std::filesystem::path(basePath) / "").string();
        auto object = std::make_shared<SceneObject>();
        object->load(document, source);
        return returnHandle(std::move(object), scene);
    });
}

NimbusStatus nimbus_scene_set_camera(NimbusScene scene, NimbusCamera camera)
{
    return guard([&] {
        auto s = sceneOf(scene);
        s->setCamera(registry().get<CameraObject>(camera, NIMBUS_TYPE_CAMERA));
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_get_camera(NimbusScene scene, NimbusCamera* camera)
{
    return guard([&] {
        required(camera, "camera");
        *camera = registry().handleFor(sceneOf(scene)->camera());
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_add_light(NimbusScene scene, NimbusLight light)
{
    return guard([&] {
        auto s = sceneOf(scene);
        s->addLight(registry().get<LightObject>(light, NIMBUS_TYPE_LIGHT));
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_remove_light(NimbusScene scene, NimbusLight light)
{
    return guard([&] {
        auto s = sceneOf(scene);
        s->removeLight(registry().get<LightObject>(light, NIMBUS_TYPE_LIGHT));
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_light_count(NimbusScene scene, size_t* count)
{
    return guard([&] {
        required(count, "count");
        *count = sceneOf(scene)->lights().size();
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_get_light(NimbusScene scene, size_t index, NimbusLight* light)
{
    return guard([&] {
        required(light, "light");
        auto lights = sceneOf(scene)->lights();
        if (index >= lights.size())
            throw ApiError(NIMBUS_ERROR_NOT_FOUND, "light index " + std::to_string(index) + " out of range (" +
                                                       std::to_string(lights.size()) + " lights)");
        *light = registry().handleFor(lights[index]);
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_add_volume(NimbusScene scene, NimbusVolume volume)
{
    return guard([&] {
        auto s = sceneOf(scene);
        s->addVolume(registry().get<VolumeObject>(volume, NIMBUS_TYPE_VOLUME));
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_remove_volume(NimbusScene scene, NimbusVolume volume)
{
    return guard([&] {
        auto s = sceneOf(scene);
        s->removeVolume(registry().get<VolumeObject>(volume, NIMBUS_TYPE_VOLUME));
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_volume_count(NimbusScene scene, size_t* count)
{
    return guard([&] {
        required(count, "count");
        *count = sceneOf(scene)->volumes().size();
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_get_volume(NimbusScene scene, size_t index, NimbusVolume* volume)
{
    return guard([&] {
        required(volume, "volume");
        auto volumes = sceneOf(scene)->volumes();
        if (index >= volumes.size())
            throw ApiError(NIMBUS_ERROR_NOT_FOUND, "volume index " + std::to_string(index) + " out of range (" +
                                                       std::to_string(volumes.size()) + " volumes)");
        *volume = registry().handleFor(volumes[index]);
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_commit(NimbusHandle object)
{
    return guard([&] {
        std::shared_ptr<ParamObject> o = paramsOf(object);
        if (o->type() == NIMBUS_TYPE_SCENE)
            std::static_pointer_cast<SceneObject>(o)->commit();
        else
            o->validate();
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_scene_to_json(NimbusScene scene, char* buffer, size_t capacity, size_t* length)
{
    return guard([&] {
        if (capacity > 0)
            required(buffer, "buffer");
        const std::string text = sceneToJson(*sceneOf(scene)->committed()).dump(2);
        if (length)
            *length = text.size();
        if (capacity < text.size() + 1) {
            if (capacity > 0)
                buffer[0] = '\0';
            throw ApiError(NIMBUS_ERROR_BUFFER_TOO_SMALL, "the buffer holds " + std::to_string(capacity) +
                                                              " bytes, the scene needs " +
                                                              std::to_string(text.size() + 1));
        }
        std::memcpy(buffer, text.c_str(), text.size() + 1);
        return NIMBUS_OK;
    });
}

// ---- cameras, lights, volumes ---------------------------------------------------------------

NimbusStatus nimbus_camera_create(NimbusCamera* camera)
{
    return guard([&] { return returnHandle(std::make_shared<CameraObject>(), required(camera, "camera")); });
}

NimbusStatus nimbus_light_create(const char* type, NimbusLight* light)
{
    return guard([&] {
        required(light, "light");
        auto object = std::make_shared<LightObject>();
        object->set("type", std::string(requiredString(type, "type")));  // the format names the types
        return returnHandle(std::move(object), light);
    });
}

NimbusStatus nimbus_volume_create(const char* sourceType, NimbusVolume* volume)
{
    return guard([&] {
        required(volume, "volume");
        auto object = std::make_shared<VolumeObject>();
        object->set("source", json{{"type", std::string(requiredString(sourceType, "source_type"))}});
        return returnHandle(std::move(object), volume);
    });
}

// ---- rendering ------------------------------------------------------------------------------

NimbusStatus nimbus_session_create(NimbusScene scene, NimbusSession* session)
{
    return guard([&] {
        required(session, "session");
        return returnHandle(std::make_shared<SessionObject>(sceneOf(scene)), session);
    });
}

NimbusStatus nimbus_session_set_progress_callback(NimbusSession session, NimbusProgressCallback callback,
                                                  void* userData)
{
    return guard([&] {
        sessionOf(session)->setProgressCallback(callback, userData);
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_session_render(NimbusSession session)
{
    return guard([&] {
        std::string message;
        NimbusStatus status = sessionOf(session)->render(message);
        return status == NIMBUS_OK ? status : fail(status, message);
    });
}

NimbusStatus nimbus_session_start(NimbusSession session)
{
    return guard([&] {
        sessionOf(session)->start();
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_session_wait(NimbusSession session, double timeoutSeconds)
{
    return guard([&] {
        if (std::isnan(timeoutSeconds))
            throw ApiError(NIMBUS_ERROR_INVALID_ARGUMENT, "timeout_seconds is NaN");
        std::string message;
        NimbusStatus status = sessionOf(session)->wait(timeoutSeconds, message);
        return status == NIMBUS_OK ? status : fail(status, message);
    });
}

NimbusStatus nimbus_session_cancel(NimbusSession session)
{
    return guard([&] {
        sessionOf(session)->cancel();
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_session_state(NimbusSession session, NimbusSessionState* state, float* progress)
{
    return guard([&] {
        NimbusSessionState s = sessionOf(session)->state(progress);
        if (state)
            *state = s;
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_session_frame(NimbusSession session, NimbusFrame* frame)
{
    return guard([&] {
        required(frame, "frame");
        *frame = registry().handleFor(sessionOf(session)->frame());
        return NIMBUS_OK;
    });
}

// ---- frames ---------------------------------------------------------------------------------

NimbusStatus nimbus_frame_aov_count(NimbusFrame frame, size_t* count)
{
    return guard([&] {
        *required(count, "count") = frameOf(frame)->result().film.aovs.size();
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_frame_aov(NimbusFrame frame, size_t index, NimbusAov* aov)
{
    return guard([&] {
        required(aov, "aov");
        auto f = frameOf(frame);
        const auto& aovs = f->result().film.aovs;
        if (index >= aovs.size())
            throw ApiError(NIMBUS_ERROR_NOT_FOUND, "AOV index " + std::to_string(index) + " out of range (" +
                                                       std::to_string(aovs.size()) + " AOVs)");
        fillAov(*f, aovs[index], aov);
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_frame_find_aov(NimbusFrame frame, const char* name, NimbusAov* aov)
{
    return guard([&] {
        required(aov, "aov");
        const std::string wanted = requiredString(name, "name");
        auto f = frameOf(frame);
        const Aov* a = f->result().film.find(wanted);
        if (!a) {
            std::string names;
            for (const Aov& each : f->result().film.aovs)
                names += (names.empty() ? "" : ", ") + each.name;
            throw ApiError(NIMBUS_ERROR_NOT_FOUND, "no AOV '" + wanted + "' (the frame has " + names + ")");
        }
        fillAov(*f, *a, aov);
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_frame_seconds(NimbusFrame frame, double* seconds)
{
    return guard([&] {
        *required(seconds, "seconds") = frameOf(frame)->result().seconds;
        return NIMBUS_OK;
    });
}

NimbusStatus nimbus_frame_write_outputs(NimbusFrame frame)
{
    return guard([&] {
        auto f = frameOf(frame);
        checkOutputs(f->scene());
        Film film = f->result().film;  // selectAovs edits its film: the frame's stays whole
        selectAovs(f->scene(), film);
        writeOutputs(f->scene(), film);
        return NIMBUS_OK;
    });
}

}  // extern "C"
