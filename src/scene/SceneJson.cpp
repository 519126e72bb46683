// SceneJson.cpp: reading and writing the JSON scene format.
//
// Each object's plain keys are listed once, in a visit function that takes either a reader or a
// writer (the field() overloads of both have the same shape), so reading and writing cannot
// drift apart and adding a key is one line. Keys whose JSON shape differs from the Scene field
// (resolution, motion, transform, phase, sources) are read and written by hand next to each other.
#include "SceneJson.h"

#include "JsonReader.h"
#include "SceneValidate.h"

#include "../core/Error.h"

#include <nlohmann/json.hpp>

#include <sys/stat.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <cstring>
#include <type_traits>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace nimbus {

using nlohmann::json;

namespace {

// ---- the two visitors ----------------------------------------------------------------------

// The JSON number whose shortest decimal reads back as exactly v: written files say 0.1, not
// 0.10000000149011612, and still round-trip bit for bit.
double shortestDecimal(float v)
{
    char buf[32];
    for (int precision = 6; precision <= 9; ++precision) {
        std::snprintf(buf, sizeof buf, "%.*g", precision, double(v));
        double d = std::strtod(buf, nullptr);
        if (float(d) == v)
            return d;
    }
    return double(v);
}

class JsonWriter {
public:
    void field(const std::string& key, float v) { mJson[key] = shortestDecimal(v); }
    void field(const std::string& key, double v) { mJson[key] = v; }
    void field(const std::string& key, int v) { mJson[key] = v; }
    void field(const std::string& key, uint32_t v) { mJson[key] = v; }
    void field(const std::string& key, bool v) { mJson[key] = v; }
    void field(const std::string& key, const std::string& v) { mJson[key] = v; }
    void field(const std::string& key, const std::vector<std::string>& v) { mJson[key] = v; }
    void field(const std::string& key, float3 v) { mJson[key] = array(v); }
    void field(const std::string& key, Method m) { mJson[key] = methodName(m); }
    void field(const std::string& key, WkbKernel k) { mJson[key] = wkbKernelName(k); }
    void field(const std::string& key, WkbSource k) { mJson[key] = wkbSourceName(k); }
    void field(const std::string& key, WkbOrder2 k) { mJson[key] = wkbOrder2Name(k); }
    void field(const std::string& key, WkbOrders3 k) { mJson[key] = wkbOrders3Name(k); }
    void field(const std::string& key, VrlSampling s) { mJson[key] = vrlSamplingName(s); }
    void field(const std::string& key, PixelFilter f) { mJson[key] = pixelFilterName(f); }
    void rgb(const std::string& key, Rgb v) { mJson[key] = array(v); }
    template <int N>
    void field(const std::string& key, const float (&v)[N])
    {
        json a = json::array();
        for (int i = 0; i < N; ++i)
            a.push_back(shortestDecimal(v[i]));
        mJson[key] = a;
    }

    static json array(float3 v) { return {shortestDecimal(v.x), shortestDecimal(v.y), shortestDecimal(v.z)}; }
    nlohmann::json& doc() { return mJson; }

    // The value, or its key list where it is animated (Animation.h).
    template <class T>
    void animated(const std::string& key, const T& value, const Keys<T>& keys)
    {
        if (!keys.animated()) {
            if constexpr (std::is_same_v<T, Transform>)
                mJson[key] = value.rowMajor();
            else
                field(key, value);
            return;
        }
        json list = json::array();
        for (size_t i = 0; i < keys.frames.size(); ++i) {
            json v;
            if constexpr (std::is_same_v<T, Transform>)
                v = keys.values[i].rowMajor();
            else if constexpr (std::is_same_v<T, float3>)
                v = array(keys.values[i]);
            else
                v = shortestDecimal(keys.values[i]);
            list.push_back({{"frame", keys.frames[i]}, {"value", v}});
        }
        mJson[key] = list;
    }

private:
    nlohmann::json mJson = nlohmann::json::object();
};

Transform readTransform(const JsonValue& v);

// A key list (Animation.h): a non-empty array whose first element is an object. Values are
// arrays of numbers or objects of another shape, so the first element tells them apart.
bool isKeyList(const json& v)
{
    return v.is_array() && !v.empty() && v.front().is_object();
}

// The reader side, with the Scene's enums.
class SceneReader : public JsonReader {
public:
    using JsonReader::field;
    using JsonReader::JsonReader;

    // key: a value, or a key list [{"frame": f, "value": v}, ...] (Animation.h). A key list
    // fills keys (sorted, frames distinct) and sets value to the first key's.
    void animated(const std::string& key, float3& value, Keys<float3>& keys)
    {
        animatedWith(key, value, keys, [](SceneReader& k) {
            float3 v = k.get("value").vec3();
            k.field("value", v);
            return v;
        });
    }
    void animated(const std::string& key, float& value, Keys<float>& keys)
    {
        animatedWith(key, value, keys, [](SceneReader& k) {
            (void)k.get("value");
            float v = 0.0f;
            k.field("value", v);
            return v;
        });
    }
    void animated(const std::string& key, Transform& value, Keys<Transform>& keys)
    {
        animatedWith(key, value, keys, [](SceneReader& k) {
            const Transform t = readTransform(k.get("value"));
            try {
                (void)splitTrs(t);  // interpolable: translate x rotate x scale
            } catch (const std::invalid_argument& e) {
                k.fail("value", e.what());
            }
            return t;
        });
    }

    void field(const std::string& key, Method& out)
    {
        const nlohmann::json* v = find(key);
        if (!v)
            return;
        std::string name = JsonValue{*v, keyPath(key), file()}.string();
        for (Method m : {Method::Single, Method::Wkb, Method::Pathtrace, Method::Vrl})
            if (name == methodName(m)) {
                out = m;
                return;
            }
        fail(key, "unknown method '" + name + "' (expected single, wkb, pathtrace, vrl)");
    }
    void field(const std::string& key, WkbKernel& out)
    {
        named(key, out, {WkbKernel::Gaussian, WkbKernel::Exact}, wkbKernelName, "angular kernel");
    }
    void field(const std::string& key, PixelFilter& out)
    {
        named(key, out, {PixelFilter::Box, PixelFilter::Gaussian, PixelFilter::BlackmanHarris}, pixelFilterName,
              "pixel filter");
    }
    void field(const std::string& key, WkbSource& out)
    {
        named(key, out, {WkbSource::Straight, WkbSource::RandomWalk}, wkbSourceName, "source placement");
    }
    void field(const std::string& key, VrlSampling& out)
    {
        named(key, out, {VrlSampling::Auto, VrlSampling::Simple, VrlSampling::Advanced}, vrlSamplingName,
              "VRL joint distribution");
    }
    void field(const std::string& key, WkbOrder2& out)
    {
        named(key, out, {WkbOrder2::Auto, WkbOrder2::Traced, WkbOrder2::Kernel, WkbOrder2::Cache}, wkbOrder2Name,
              "order-2 model");
    }
    void field(const std::string& key, WkbOrders3& out)
    {
        named(key, out, {WkbOrders3::Kernel, WkbOrders3::Traced}, wkbOrders3Name, "orders-3+ model");
    }

private:
    template <class T, class ReadValue>
    void animatedWith(const std::string& key, T& value, Keys<T>& keys, ReadValue readValue)
    {
        const json* v = find(key);
        if (!v)
            return;
        if (!isKeyList(*v)) {
            if constexpr (std::is_same_v<T, Transform>)
                value = readTransform(JsonValue{*v, keyPath(key), file()});
            else
                field(key, value);
            return;
        }
        std::vector<std::pair<double, T>> list;
        for (size_t i = 0; i < v->size(); ++i) {
            const std::string path = keyPath(key) + "[" + std::to_string(i) + "]";
            if (!(*v)[i].is_object())
                JsonValue{(*v)[i], path, file()}.typeError("a key {\"frame\": number, \"value\": ...}");
            SceneReader k((*v)[i], path, file());
            const double frame = k.get("frame").number();
            T item = readValue(k);
            k.finish(" in an animation key (frame, value)");
            for (const auto& [f, unused] : list)
                if (f == frame)
                    JsonValue{(*v)[i], path, file()}.fail("a second key at frame " + nlohmann::json(frame).dump());
            list.emplace_back(frame, item);
        }
        std::stable_sort(list.begin(), list.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        keys = Keys<T>{};
        for (auto& [f, item] : list) {
            keys.frames.push_back(f);
            keys.values.push_back(item);
        }
        value = keys.values.front();
    }

    template <class E>
    void named(const std::string& key, E& out, std::initializer_list<E> values, const char* (*name)(E),
               const char* what)
    {
        const nlohmann::json* v = find(key);
        if (!v)
            return;
        std::string given = JsonValue{*v, keyPath(key), file()}.string();
        std::string expected;
        for (E e : values) {
            if (given == name(e)) {
                out = e;
                return;
            }
            expected += (expected.empty() ? "" : ", ") + std::string(name(e));
        }
        fail(key, "unknown " + std::string(what) + " '" + given + "' (expected " + expected + ")");
    }
};

const json& requireList(const JsonValue& v)
{
    if (!v.value.is_array())
        v.typeError("a list");
    return v.value;
}

std::string indexed(const std::string& path, size_t i)
{
    return path + "[" + std::to_string(i) + "]";
}

// A file named in the scene (VDB, mesh, depth image), relative to the scene file, so that a
// scene directory can move as a whole.
std::string relativeToScene(const std::string& path, const std::string& sourcePath)
{
    std::filesystem::path file(path);
    std::filesystem::path dir = std::filesystem::path(sourcePath).parent_path();
    if (!path.empty() && file.is_relative() && !dir.empty())
        return (dir / file).lexically_normal().string();
    return path;
}

// ---- render, output ------------------------------------------------------------------------

template <class V, class R>
void visitRender(V& v, R& r)
{
    v.field("method", r.method);
    v.field("seed", r.seed);
    v.field("frame", r.frame);
    v.field("fps", r.fps);
    v.field("threads", r.threads);
    v.field("spp", r.spp);
    v.field("adaptive_threshold", r.adaptiveThreshold);
    v.field("adaptive_max_spp", r.adaptiveMaxSpp);
    v.field("pixel_filter", r.pixelFilter);
    v.field("filter_width", r.filterWidth);
    v.field("step", r.step);
    v.field("shadow_map_resolution", r.shadowMapResolution);
    v.field("tolerance", r.tolerance);
    v.field("shadow_step", r.shadowStep);
    v.field("light_samples", r.lightSamples);
    v.field("emission_samples", r.emissionSamples);
    v.field("max_depth", r.maxDepth);
    v.field("time_limit", r.timeLimit);
    v.field("noise_target", r.noiseTarget);
    v.field("equiangular", r.equiangular);
    v.field("vrl_paths", r.vrlPaths);
    v.field("vrl_sampling", r.vrlSampling);
    v.field("wkb_kernel", r.wkbKernel);
    v.field("wkb_source", r.wkbSource);
    v.field("wkb_order2", r.wkbOrder2);
    v.field("wkb_order2_samples", r.wkbOrder2Samples);
    v.field("wkb_orders3", r.wkbOrders3);
    v.field("wkb_orders3_paths", r.wkbOrders3Paths);
    v.field("wkb_orders3_grid", r.wkbOrders3Grid);
    v.field("wkb_blur_k", r.wkbBlurK);
    v.field("wkb_l_step", r.wkbLStep);
    v.field("wkb_order_max", r.wkbOrderMax);
    v.field("wkb_sh_order_max", r.wkbShOrderMax);
    v.field("light_volume_resolution", r.lightVolumeResolution);
    v.field("wkb_memory_budget", r.wkbMemoryBudget);
    v.field("memory_limit", r.memoryLimit);
}

template <class V, class O>
void visitOutput(V& v, O& o)
{
    v.field("file", o.file);
    v.field("preview", o.preview);
    v.field("preview_view", o.previewView);
    v.field("preview_look", o.previewLook);
    v.field("exposure", o.exposure);
    v.field("aovs", o.aovs);
    v.field("deep", o.deep);
    v.field("deep_samples", o.deepSamples);
}

// ---- camera --------------------------------------------------------------------------------

template <class V, class C>
void visitCamera(V& v, C& c)
{
    v.animated("from", c.from, c.fromKeys);
    v.animated("to", c.to, c.toKeys);
    v.animated("up", c.up, c.upKeys);
    v.animated("fov", c.fov, c.fovKeys);
    v.field("crop", c.crop);
}

Camera readCamera(SceneReader r, const std::string& sourcePath)
{
    Camera c;
    visitCamera(r, c);
    if (const json* v = r.find("resolution")) {
        JsonValue res{*v, r.keyPath("resolution"), r.file()};
        if (!v->is_array() || v->size() != 2)
            res.typeError("[width, height], an array of 2 integers");
        c.width = int(JsonValue{(*v)[0], indexed(res.path, 0), r.file()}.integer(INT32_MIN, INT32_MAX));
        c.height = int(JsonValue{(*v)[1], indexed(res.path, 1), r.file()}.integer(INT32_MIN, INT32_MAX));
    }
    float shutter[2] = {c.shutterOpen, c.shutterClose};
    bool hasShutter = r.has("shutter");
    r.field("shutter", shutter);
    if (const json* v = r.find("motion")) {
        // The pose at shutter close; what it leaves out stays as at shutter open.
        SceneReader m(*v, r.keyPath("motion"), r.file());
        if (c.fromKeys.animated() || c.toKeys.animated() || c.upKeys.animated())
            r.fail("motion", "give the camera's motion either as animation keys of from, to, up or as this pose at "
                       "shutter close, not both");
        c.hasMotion = true;
        c.fromClose = c.from, c.toClose = c.to, c.upClose = c.up;
        m.field("from", c.fromClose);
        m.field("to", c.toClose);
        m.field("up", c.upClose);
        m.finish();
        // Motion without a shutter interval would blur nothing; open for a whole frame.
        if (!hasShutter)
            shutter[0] = 0.0f, shutter[1] = 1.0f;
    }
    c.shutterOpen = shutter[0], c.shutterClose = shutter[1];
    if (const json* v = r.find("holdout_depth")) {
        SceneReader h(*v, r.keyPath("holdout_depth"), r.file());
        c.holdoutDepth.file = relativeToScene(h.get("file").string(), sourcePath);
        h.field("channel", c.holdoutDepth.channel);
        h.finish();
    }
    r.finish();
    return c;
}

json writeCamera(const Camera& c)
{
    JsonWriter w;
    visitCamera(w, c);
    w.doc()["resolution"] = {c.width, c.height};
    if (c.hasMotion || c.shutterOpen != 0.0f || c.shutterClose != 0.0f) {
        const float shutter[2] = {c.shutterOpen, c.shutterClose};
        w.field("shutter", shutter);
    }
    if (c.hasMotion)
        w.doc()["motion"] = {{"from", JsonWriter::array(c.fromClose)},
                             {"to", JsonWriter::array(c.toClose)},
                             {"up", JsonWriter::array(c.upClose)}};
    if (!c.holdoutDepth.file.empty())
        w.doc()["holdout_depth"] = {{"file", c.holdoutDepth.file}, {"channel", c.holdoutDepth.channel}};
    return w.doc();
}

// ---- lights --------------------------------------------------------------------------------

const LightType kLightTypes[] = {LightType::Distant, LightType::Point,  LightType::Spot,
                                 LightType::Rect,    LightType::Sphere, LightType::Environment};

// A light has the keys of its type only: a cone_angle on a point light is a mistake to report,
// not a value to carry.
template <class V, class L>
void visitLight(V& v, L& l)
{
    switch (l.type) {
    case LightType::Distant:
        v.animated("direction", l.direction, l.directionKeys);
        v.rgb("irradiance", l.irradiance);
        v.field("angle", l.angle);
        break;
    case LightType::Point:
        v.animated("position", l.position, l.positionKeys);
        v.rgb("intensity", l.intensity);
        break;
    case LightType::Spot:
        v.animated("position", l.position, l.positionKeys);
        v.animated("direction", l.direction, l.directionKeys);
        v.rgb("intensity", l.intensity);
        v.field("cone_angle", l.coneAngle);
        v.field("cone_softness", l.coneSoftness);
        break;
    case LightType::Rect:
        v.animated("center", l.center, l.centerKeys);
        v.animated("normal", l.normal, l.normalKeys);
        v.animated("up", l.up, l.upKeys);
        v.field("size", l.size);
        v.rgb("radiance", l.radiance);
        break;
    case LightType::Sphere:
        v.animated("position", l.position, l.positionKeys);
        v.field("radius", l.radius);
        v.rgb("radiance", l.radiance);
        break;
    case LightType::Environment:
        v.rgb("radiance", l.radiance);
        v.field("rotate", l.rotate);
        v.field("intensity", l.mapIntensity);
        break;
    }
}

Light readLight(SceneReader r, size_t index)
{
    Light l;
    std::string type = r.get("type").string();
    bool known = false;
    for (LightType t : kLightTypes)
        if (type == lightTypeName(t))
            l.type = t, known = true;
    if (!known)
        r.fail("type", "unknown light type '" + type + "' (expected distant, point, spot, rect, sphere, environment)");
    l.name = std::to_string(index);
    r.field("name", l.name);
    if (l.type == LightType::Environment)
        if (const json* m = r.find("map"))
            l.map = relativeToScene(JsonValue{*m, r.keyPath("map"), r.file()}.string(), r.file());
    visitLight(r, l);
    r.finish(" for a " + type + " light");
    return l;
}

json writeLight(const Light& l)
{
    JsonWriter w;
    w.doc()["type"] = lightTypeName(l.type);
    if (!l.name.empty())
        w.field("name", l.name);
    if (!l.map.empty())
        w.field("map", l.map);
    visitLight(w, l);
    return w.doc();
}

// ---- volumes -------------------------------------------------------------------------------

VolumeSource readSource(SceneReader r, const std::string& sourcePath)
{
    VolumeSource s;
    std::string type = r.get("type").string();
    if (type == "vdb") {
        s.type = SourceType::Vdb;
        s.file = relativeToScene(r.get("file").string(), sourcePath);
        if (const json* grids = r.find("grids")) {
            SceneReader g(*grids, r.keyPath("grids"), r.file());
            g.markAllRead();
            for (const auto& item : grids->items()) {
                std::string name = JsonValue{item.value(), g.keyPath(item.key()), r.file()}.string();
                s.grids[item.key() == "heat" ? "flame" : item.key()] = name;  // DESIGN: heat is flame
            }
        }
    } else if (type == "procedural") {
        s.type = SourceType::Procedural;
        r.field("generator", s.generator);
        // Every other key is a numeric generator parameter; the generator checks the names.
        for (const auto& item : r.value().items()) {
            if (item.key() == "type" || item.key() == "generator")
                continue;
            s.params[item.key()] = JsonValue{item.value(), r.keyPath(item.key()), r.file()}.number();
        }
        r.markAllRead();
    } else if (type == "plugin") {
        s.type = SourceType::Plugin;
        s.pluginPath = r.get("path").string();
        if (const json* params = r.find("params")) {
            SceneReader p(*params, r.keyPath("params"), r.file());
            p.markAllRead();
            for (const auto& item : params->items()) {
                JsonValue v{item.value(), p.keyPath(item.key()), r.file()};
                if (!v.value.is_string() && !v.value.is_number())
                    v.typeError("a string or a number");
                s.pluginParams[item.key()] = v.value.is_string() ? v.string() : v.value.dump();
            }
        }
    } else {
        r.fail("type", "unknown source type '" + type + "' (expected vdb, procedural, plugin)");
    }
    r.finish(" for a " + type + " source");
    return s;
}

json writeSource(const VolumeSource& s)
{
    json j;
    switch (s.type) {
    case SourceType::Vdb:
        j = {{"type", "vdb"}, {"file", s.file}, {"grids", json::object()}};
        for (const auto& [role, grid] : s.grids)
            j["grids"][role] = grid;
        break;
    case SourceType::Procedural:
        j = {{"type", "procedural"}, {"generator", s.generator}};
        for (const auto& [key, value] : s.params)
            j[key] = value;
        break;
    case SourceType::Plugin:
        j = {{"type", "plugin"}, {"path", s.pluginPath}, {"params", json::object()}};
        for (const auto& [key, value] : s.pluginParams)
            j["params"][key] = value;
        break;
    }
    return j;
}

// A row-major 4x4 matrix, or scale, then rotate, then translate (the order artists expect from
// a TRS gizmo: the volume is sized about its own origin, then turned, then placed).
Transform readTransform(const JsonValue& v)
{
    const json& j = v.value;
    auto element = [&](const json& a, const std::string& path, size_t i) {
        return JsonValue{a[i], indexed(path, i), v.file}.number();
    };
    if (j.is_array()) {
        if (j.size() != 16)
            v.typeError("a row-major matrix of 16 numbers");
        std::array<double, 16> m;
        for (size_t i = 0; i < 16; ++i)
            m[i] = element(j, v.path, i);
        return Transform::fromRowMajor(m);
    }
    if (!j.is_object())
        v.typeError("a row-major matrix of 16 numbers or an object {translate, rotate, scale}");
    SceneReader r(j, v.path, v.file);
    Transform t;
    if (const json* s = r.find("scale")) {
        JsonValue sv{*s, r.keyPath("scale"), v.file};
        if (s->is_number()) {
            double k = sv.number();
            t = Transform::scale(k, k, k);
        } else {
            if (!s->is_array() || s->size() != 3)
                sv.typeError("a number or an array of 3 numbers");
            t = Transform::scale(element(*s, sv.path, 0), element(*s, sv.path, 1), element(*s, sv.path, 2));
        }
    }
    if (const json* rot = r.find("rotate")) {
        JsonValue rv{*rot, r.keyPath("rotate"), v.file};
        if (!rot->is_array() || rot->size() != 4)
            rv.typeError("[angle_degrees, axis_x, axis_y, axis_z], an array of 4 numbers");
        double a[4];
        for (size_t i = 0; i < 4; ++i)
            a[i] = element(*rot, rv.path, i);
        if (a[1] == 0 && a[2] == 0 && a[3] == 0)
            rv.fail("the rotation axis must be a non-zero vector");
        t = Transform::rotateDegrees(a[0], a[1], a[2], a[3]) * t;
    }
    if (const json* tr = r.find("translate")) {
        JsonValue tv{*tr, r.keyPath("translate"), v.file};
        if (!tr->is_array() || tr->size() != 3)
            tv.typeError("an array of 3 numbers");
        t = Transform::translate(element(*tr, tv.path, 0), element(*tr, tv.path, 1), element(*tr, tv.path, 2)) * t;
    }
    r.finish();
    return t;
}

template <class V, class M>
void visitMedium(V& v, M& m)
{
    v.rgb("sigma_s", m.sigma_s);
    v.rgb("sigma_a", m.sigma_a);
    v.field("density_scale", m.densityScale);
    v.field("emission_scale", m.emissionScale);
    v.field("velocity_scale", m.velocityScale);
}

NbPhase readPhase(SceneReader r)
{
    NbPhase p = {0.0f, 0.0f, 0.0f, 0.0f};
    std::string type = "hg";
    r.field("type", type);
    // "hg" with g2 and blend is the same two-lobe function; both spellings are accepted.
    if (type != "hg" && type != "hg2" && type != "two_lobe")
        r.fail("type", "unknown phase function '" + type + "' (expected hg, hg2)");
    r.field("g", p.g);
    r.field("g2", p.g2);
    r.field("blend", p.blend);
    r.finish();
    return p;
}

json writePhase(const NbPhase& p)
{
    if (p.g2 == 0.0f && p.blend == 0.0f)
        return {{"type", "hg"}, {"g", shortestDecimal(p.g)}};
    return {{"type", "hg2"},
            {"g", shortestDecimal(p.g)},
            {"g2", shortestDecimal(p.g2)},
            {"blend", shortestDecimal(p.blend)}};
}

Medium readMedium(SceneReader r)
{
    Medium m;
    visitMedium(r, m);
    if (const json* p = r.find("phase"))
        m.phase = readPhase(SceneReader(*p, r.keyPath("phase"), r.file()));
    r.finish();
    return m;
}

Volume readVolume(SceneReader r, size_t index, const std::string& sourcePath)
{
    Volume v;
    v.name = "volume" + std::to_string(index);
    r.field("name", v.name);
    v.source = readSource(SceneReader(r.get("source").value, r.keyPath("source"), r.file()), sourcePath);
    r.animated("transform", v.transform, v.transformKeys);
    if (const json* m = r.find("medium"))
        v.medium = readMedium(SceneReader(*m, r.keyPath("medium"), r.file()));
    r.field("shader", v.shader);
    r.finish();
    return v;
}

json writeVolume(const Volume& v)
{
    JsonWriter medium;
    visitMedium(medium, v.medium);
    medium.doc()["phase"] = writePhase(v.medium.phase);
    json j = {{"name", v.name}, {"source", writeSource(v.source)}, {"medium", medium.doc()}};
    JsonWriter placement;
    placement.animated("transform", v.transform, v.transformKeys);
    j["transform"] = placement.doc()["transform"];
    if (!v.shader.empty())
        j["shader"] = v.shader;
    return j;
}

// ---- geometry ------------------------------------------------------------------------------

const GeometryType kGeometryTypes[] = {GeometryType::Mesh, GeometryType::Sphere, GeometryType::Plane};

// An object has the keys of its type only (a radius on a mesh is a mistake to report), and
// the placement and flags every type shares.
Geometry readGeometry(SceneReader r, size_t index, const std::string& sourcePath)
{
    Geometry g;
    g.name = "geometry" + std::to_string(index);
    std::string type = r.get("type").string();
    bool known = false;
    for (GeometryType t : kGeometryTypes)
        if (type == geometryTypeName(t))
            g.type = t, known = true;
    if (!known)
        r.fail("type", "unknown geometry type '" + type + "' (expected mesh, sphere, plane)");
    r.field("name", g.name);
    switch (g.type) {
    case GeometryType::Mesh: g.file = relativeToScene(r.get("file").string(), sourcePath); break;
    case GeometryType::Sphere: r.field("radius", g.radius); break;
    case GeometryType::Plane:
        g.bounded = r.has("size");
        r.field("size", g.size);
        break;
    }
    r.animated("transform", g.transform, g.transformKeys);
    r.field("holdout", g.holdout);
    r.field("shadows", g.shadows);
    r.finish(" for a " + type);
    return g;
}

json writeGeometry(const Geometry& g)
{
    JsonWriter w;
    w.field("name", g.name);
    w.doc()["type"] = geometryTypeName(g.type);
    switch (g.type) {
    case GeometryType::Mesh: w.field("file", g.file); break;
    case GeometryType::Sphere: w.field("radius", g.radius); break;
    case GeometryType::Plane:
        if (g.bounded)
            w.field("size", g.size);
        break;
    }
    w.animated("transform", g.transform, g.transformKeys);
    w.field("holdout", g.holdout);
    w.field("shadows", g.shadows);
    return w.doc();
}

// Byte offset to "line L, column C", both from 1, as editors count them.
std::string lineColumn(const std::string& text, size_t offset)
{
    size_t line = 1, column = 1;
    for (size_t i = 0; i < offset && i < text.size(); ++i) {
        if (text[i] == '\n')
            ++line, column = 1;
        else
            ++column;
    }
    return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

}  // namespace

json readJsonFile(const std::string& path)
{
    // Only a regular file of sane size is read: /dev/zero, a FIFO or a runaway file would be read
    // until memory ran out (issue 18, failure 8). stat() first, then a bounded read, since some
    // files (/proc) report a size of 0.
    struct stat st;
    if (::stat(path.c_str(), &st) != 0)
        throw InputError(path + ": cannot open scene file: " + std::strerror(errno));
    if (S_ISDIR(st.st_mode))
        throw InputError(path + ": cannot open scene file: " + std::strerror(EISDIR));
    if (!S_ISREG(st.st_mode))
        throw InputError(path + ": cannot open scene file: not a regular file (a device, FIFO or socket)");
    if (uint64_t(st.st_size) > kMaxSceneFileBytes)
        throw InputError(path + ": cannot open scene file: " + std::to_string(st.st_size) + " bytes, more than the " +
                         std::to_string(kMaxSceneFileBytes >> 20) + " MiB a scene file may have");
    errno = 0;
    std::ifstream in(path, std::ios::binary);
    if (!in)
        throw InputError(path + ": cannot open scene file: " + (errno ? std::strerror(errno) : "unreadable"));
    std::string text;
    text.reserve(size_t(st.st_size));
    char chunk[1 << 16];
    while (text.size() <= kMaxSceneFileBytes && in.read(chunk, sizeof chunk).gcount() > 0)
        text.append(chunk, size_t(in.gcount()));
    if (text.size() > kMaxSceneFileBytes)
        throw InputError(path + ": cannot open scene file: more than the " + std::to_string(kMaxSceneFileBytes >> 20) +
                         " MiB a scene file may have");
    try {
        return parseJsonRejectingDuplicateKeys(text, path);
    } catch (const json::parse_error& e) {
        // nlohmann's message is "[json.exception.parse_error.101] parse error at line L, column
        // C: <what>"; keep <what> and say where in our own words.
        std::string what = e.what();
        size_t colon = what.find(": ", what.find("parse error"));
        what = colon == std::string::npos ? what : what.substr(colon + 2);
        size_t offset = e.byte > 0 ? e.byte - 1 : 0;
        throw InputError(path + ": invalid JSON at " + lineColumn(text, offset) + ": " + what);
    } catch (const json::exception& e) {
        // Number overflow ("1e999") is reported without a position; find the literal.
        std::string what = e.what();
        size_t q0 = what.find('\''), q1 = what.rfind('\'');
        size_t at = q0 < q1 ? text.find(what.substr(q0 + 1, q1 - q0 - 1)) : std::string::npos;
        size_t colon = what.find("] ");
        what = colon == std::string::npos ? what : what.substr(colon + 2);
        throw InputError(path + ": invalid JSON at " + lineColumn(text, at == std::string::npos ? 0 : at) + ": " +
                         what);
    }
}

Scene sceneFromJson(const json& document, const std::string& sourcePath)
{
    Scene s;
    s.sourcePath = sourcePath;
    SceneReader r(document, "", sourcePath);
    if (const json* v = r.find("version")) {
        int64_t version = JsonValue{*v, "version", sourcePath}.integer(INT32_MIN, INT32_MAX);
        if (version != kSceneFormatVersion)
            r.fail("version", "this nimbus reads scene format version " + std::to_string(kSceneFormatVersion) +
                                  ", got " + std::to_string(version));
    }
    if (const json* v = r.find("camera"))
        s.camera = readCamera(SceneReader(*v, "camera", sourcePath), sourcePath);
    if (const json* v = r.find("lights")) {
        const json& list = requireList(JsonValue{*v, "lights", sourcePath});
        for (size_t i = 0; i < list.size(); ++i)
            s.lights.push_back(readLight(SceneReader(list[i], indexed("lights", i), sourcePath), i));
    }
    if (const json* v = r.find("volumes")) {
        const json& list = requireList(JsonValue{*v, "volumes", sourcePath});
        for (size_t i = 0; i < list.size(); ++i)
            s.volumes.push_back(readVolume(SceneReader(list[i], indexed("volumes", i), sourcePath), i, sourcePath));
    }
    if (const json* v = r.find("geometry")) {
        const json& list = requireList(JsonValue{*v, "geometry", sourcePath});
        for (size_t i = 0; i < list.size(); ++i)
            s.geometry.push_back(readGeometry(SceneReader(list[i], indexed("geometry", i), sourcePath), i, sourcePath));
    }
    if (const json* v = r.find("render")) {
        SceneReader render(*v, "render", sourcePath);
        visitRender(render, s.render);
        render.finish();
    }
    if (const json* v = r.find("output")) {
        SceneReader output(*v, "output", sourcePath);
        visitOutput(output, s.output);
        output.finish();
    }
    r.rgb("background", s.background);
    r.finish();
    validateScene(s);
    return s;
}

Scene loadSceneFile(const std::string& path, const std::vector<std::string>& overrides)
{
    json document = readJsonFile(path);
    applyOverrides(document, overrides, path);
    return sceneFromJson(document, path);
}

json sceneToJson(const Scene& s)
{
    json j;
    j["version"] = kSceneFormatVersion;
    j["camera"] = writeCamera(s.camera);
    j["lights"] = json::array();
    for (const Light& l : s.lights)
        j["lights"].push_back(writeLight(l));
    j["volumes"] = json::array();
    for (const Volume& v : s.volumes)
        j["volumes"].push_back(writeVolume(v));
    // Written only where there is some, so that scenes without geometry read as they did.
    if (!s.geometry.empty()) {
        j["geometry"] = json::array();
        for (const Geometry& g : s.geometry)
            j["geometry"].push_back(writeGeometry(g));
    }
    JsonWriter render, output;
    visitRender(render, s.render);
    visitOutput(output, s.output);
    j["render"] = render.doc();
    j["output"] = output.doc();
    j["background"] = JsonWriter::array(s.background);
    return j;
}

}  // namespace nimbus
