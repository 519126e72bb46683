// nimbus.hpp: a header-only C++ wrapper over the C ABI (nimbus.h): RAII handles that retain on
// copy and release on destruction, std::string parameters, exceptions instead of status codes.
//
//   nimbus::embed::Scene scene = nimbus::embed::Scene::load("shot.json");
//   scene.set("render.spp", 16);
//   scene.commit();
//   nimbus::embed::Session session(scene);
//   session.onProgress([](float f) { std::printf("%.0f%%\n", 100 * f); return true; });
//   nimbus::embed::Frame frame = session.render();
//   NimbusAov beauty = frame.aov("beauty");  // valid while `frame` (or a copy) lives
//
// It only calls the C functions, so a plugin built with another compiler or standard library
// than nimbus links against the C ABI alone.
#pragma once

#include "nimbus.h"

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace nimbus::embed {

class Exception : public std::runtime_error {
public:
    Exception(NimbusStatus status, const std::string& message) : std::runtime_error(message), mStatus(status) {}
    NimbusStatus status() const { return mStatus; }

private:
    NimbusStatus mStatus;
};

inline void check(NimbusStatus status)
{
    if (status != NIMBUS_OK)
        throw Exception(status, nimbus_last_error());
}

// One reference to a handle.
class Handle {
public:
    Handle() = default;
    // Takes over a reference the caller owns (from a create / load / get).
    static Handle adopt(NimbusHandle h)
    {
        Handle o;
        o.mHandle = h;
        return o;
    }
    Handle(const Handle& o) : mHandle(o.mHandle)
    {
        if (mHandle)
            check(nimbus_retain(mHandle));
    }
    Handle(Handle&& o) noexcept : mHandle(std::exchange(o.mHandle, NIMBUS_NULL_HANDLE)) {}
    Handle& operator=(Handle o) noexcept
    {
        std::swap(mHandle, o.mHandle);
        return *this;
    }
    ~Handle()
    {
        if (mHandle)
            nimbus_release(mHandle);  // cannot fail for a handle this wrapper owns
    }

    NimbusHandle get() const { return mHandle; }
    explicit operator bool() const { return mHandle != NIMBUS_NULL_HANDLE; }

protected:
    NimbusHandle mHandle = NIMBUS_NULL_HANDLE;
};

// Scenes, cameras, lights and volumes: parameters by scene-format key path.
class Object : public Handle {
public:
    using Handle::Handle;
    Object(Handle h) : Handle(std::move(h)) {}

    Object& set(const std::string& name, int v) { return set(name, int64_t(v)); }
    Object& set(const std::string& name, int64_t v) { return checked(nimbus_set_int(mHandle, name.c_str(), v)); }
    Object& set(const std::string& name, double v) { return checked(nimbus_set_float(mHandle, name.c_str(), v)); }
    Object& set(const std::string& name, const char* v) { return checked(nimbus_set_string(mHandle, name.c_str(), v)); }
    Object& set(const std::string& name, const std::string& v) { return set(name, v.c_str()); }
    Object& set(const std::string& name, double x, double y, double z)
    {
        return checked(nimbus_set_float3(mHandle, name.c_str(), x, y, z));
    }
    Object& set(const std::string& name, const std::vector<double>& v)
    {
        return checked(nimbus_set_floats(mHandle, name.c_str(), v.data(), v.size()));
    }
    Object& set(const std::string& name, const std::vector<std::string>& v)
    {
        std::vector<const char*> p;
        for (const auto& s : v)
            p.push_back(s.c_str());
        return checked(nimbus_set_strings(mHandle, name.c_str(), p.data(), p.size()));
    }
    Object& setJson(const std::string& name, const std::string& json)
    {
        return checked(nimbus_set_json(mHandle, name.c_str(), json.c_str()));
    }
    Object& unset(const std::string& name) { return checked(nimbus_unset(mHandle, name.c_str())); }
    void commit() { check(nimbus_commit(mHandle)); }

private:
    Object& checked(NimbusStatus s)
    {
        check(s);
        return *this;
    }
};

class Camera : public Object {
public:
    explicit Camera(Handle h) : Object(std::move(h)) {}
    static Camera create()
    {
        NimbusCamera h;
        check(nimbus_camera_create(&h));
        return Camera(adopt(h));
    }
};

class Light : public Object {
public:
    explicit Light(Handle h) : Object(std::move(h)) {}
    static Light create(const std::string& type)
    {
        NimbusLight h;
        check(nimbus_light_create(type.c_str(), &h));
        return Light(adopt(h));
    }
};

class Volume : public Object {
public:
    explicit Volume(Handle h) : Object(std::move(h)) {}
    static Volume create(const std::string& sourceType)
    {
        NimbusVolume h;
        check(nimbus_volume_create(sourceType.c_str(), &h));
        return Volume(adopt(h));
    }
};

class Scene : public Object {
public:
    explicit Scene(Handle h) : Object(std::move(h)) {}
    static Scene create()
    {
        NimbusScene h;
        check(nimbus_scene_create(&h));
        return Scene(adopt(h));
    }
    static Scene load(const std::string& path)
    {
        NimbusScene h;
        check(nimbus_scene_load_file(path.c_str(), &h));
        return Scene(adopt(h));
    }
    static Scene fromJson(const std::string& json, const std::string& baseDir = "")
    {
        NimbusScene h;
        check(nimbus_scene_load_json(json.c_str(), baseDir.empty() ? nullptr : baseDir.c_str(), &h));
        return Scene(adopt(h));
    }

    void setCamera(const Camera& c) { check(nimbus_scene_set_camera(mHandle, c.get())); }
    Camera camera() const
    {
        NimbusCamera h;
        check(nimbus_scene_get_camera(mHandle, &h));
        return Camera(adopt(h));
    }
    void add(const Light& l) { check(nimbus_scene_add_light(mHandle, l.get())); }
    void remove(const Light& l) { check(nimbus_scene_remove_light(mHandle, l.get())); }
    void add(const Volume& v) { check(nimbus_scene_add_volume(mHandle, v.get())); }
    void remove(const Volume& v) { check(nimbus_scene_remove_volume(mHandle, v.get())); }
    std::vector<Light> lights() const
    {
        size_t n;
        check(nimbus_scene_light_count(mHandle, &n));
        std::vector<Light> out;
        for (size_t i = 0; i < n; ++i) {
            NimbusLight h;
            check(nimbus_scene_get_light(mHandle, i, &h));
            out.emplace_back(adopt(h));
        }
        return out;
    }
    std::vector<Volume> volumes() const
    {
        size_t n;
        check(nimbus_scene_volume_count(mHandle, &n));
        std::vector<Volume> out;
        for (size_t i = 0; i < n; ++i) {
            NimbusVolume h;
            check(nimbus_scene_get_volume(mHandle, i, &h));
            out.emplace_back(adopt(h));
        }
        return out;
    }
    std::string toJson() const
    {
        size_t n = 0;
        NimbusStatus s = nimbus_scene_to_json(mHandle, nullptr, 0, &n);
        if (s != NIMBUS_ERROR_BUFFER_TOO_SMALL)
            check(s);
        std::string text(n + 1, '\0');
        check(nimbus_scene_to_json(mHandle, &text[0], text.size(), &n));
        text.resize(n);
        return text;
    }
};

class Frame : public Handle {
public:
    explicit Frame(Handle h) : Handle(std::move(h)) {}
    std::vector<NimbusAov> aovs() const
    {
        size_t n;
        check(nimbus_frame_aov_count(mHandle, &n));
        std::vector<NimbusAov> out(n);
        for (size_t i = 0; i < n; ++i)
            check(nimbus_frame_aov(mHandle, i, &out[i]));
        return out;
    }
    NimbusAov aov(const std::string& name) const
    {
        NimbusAov a;
        check(nimbus_frame_find_aov(mHandle, name.c_str(), &a));
        return a;
    }
    double seconds() const
    {
        double s;
        check(nimbus_frame_seconds(mHandle, &s));
        return s;
    }
    void writeOutputs() const { check(nimbus_frame_write_outputs(mHandle)); }
};

class Session : public Handle {
public:
    explicit Session(const Scene& scene) { check(nimbus_session_create(scene.get(), &mHandle)); }
    // The callback runs on a render thread; it must outlive the render (this wrapper and its
    // copies keep it alive).
    void onProgress(std::function<bool(float)> callback)
    {
        mCallback = std::make_shared<std::function<bool(float)>>(std::move(callback));
        check(nimbus_session_set_progress_callback(mHandle, *mCallback ? &Session::trampoline : nullptr,
                                                   mCallback.get()));
    }
    Frame render()
    {
        check(nimbus_session_render(mHandle));
        return frame();
    }
    void start() { check(nimbus_session_start(mHandle)); }
    // True when the render finished (throws if it failed or was cancelled), false on timeout.
    bool wait(double timeoutSeconds = -1.0)
    {
        NimbusStatus s = nimbus_session_wait(mHandle, timeoutSeconds);
        if (s == NIMBUS_ERROR_TIMEOUT)
            return false;
        check(s);
        return true;
    }
    void cancel() { check(nimbus_session_cancel(mHandle)); }
    Frame frame() const
    {
        NimbusFrame h;
        check(nimbus_session_frame(mHandle, &h));
        return Frame(adopt(h));
    }

private:
    static int trampoline(float fraction, void* user)
    {
        try {
            return (*static_cast<std::function<bool(float)>*>(user))(fraction) ? 1 : 0;
        } catch (...) {
            return 0;  // an exception must not cross the C ABI: it cancels instead
        }
    }
    std::shared_ptr<std::function<bool(float)>> mCallback;
};

}  // namespace nimbus::embed
