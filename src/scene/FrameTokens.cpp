#include "FrameTokens.h"

#include "../../kernels/shared/camera.h"
#include "../core/Error.h"
#include "../core/Log.h"

#include <algorithm>
#include <cctype>

namespace nimbus {

namespace {

bool isIdentifierChar(char c)
{
    return std::isalpha(static_cast<unsigned char>(c)) || c == '_';
}

// The token starting at path[i], if any: its length and the padding width it asks for (1: none).
bool tokenAt(const std::string& path, size_t i, size_t& length, int& width)
{
    if (path[i] == '#') {
        size_t j = i;
        while (j < path.size() && path[j] == '#')
            ++j;
        length = j - i;
        width = int(std::min<size_t>(length, kMaxFramePadding));
        return true;
    }
    if (path[i] != '$' || i + 1 >= path.size() || path[i + 1] != 'F')
        return false;
    size_t j = i + 2;
    while (j < path.size() && std::isdigit(static_cast<unsigned char>(path[j])))
        ++j;
    if (j == i + 2 && j < path.size() && isIdentifierChar(path[j]))
        return false;  // $FPS, $FSTART, $Fx: another variable
    length = j - i;
    width = 1;
    for (size_t k = i + 2; k < j; ++k)  // saturating: "$F99999999999" asks for the widest
        width = std::min(kMaxFramePadding, (k == i + 2 ? 0 : width) * 10 + (path[k] - '0'));
    return true;
}

}  // namespace

std::string padFrame(long long frame, int width)
{
    const bool negative = frame < 0;
    // The magnitude as unsigned: -LLONG_MIN overflows a long long.
    unsigned long long magnitude = negative ? 0ull - static_cast<unsigned long long>(frame) : frame;
    std::string digits = std::to_string(magnitude);
    const int signWidth = negative ? 1 : 0;
    const int zeros = std::max(0, width - signWidth - int(digits.size()));
    return (negative ? "-" : "") + std::string(size_t(zeros), '0') + digits;
}

std::string expandFrameTokens(const std::string& path, long long frame)
{
    std::string out;
    out.reserve(path.size() + 8);
    size_t length = 0;
    int width = 1;
    for (size_t i = 0; i < path.size();) {
        if (tokenAt(path, i, length, width)) {
            out += padFrame(frame, width);
            i += length;
        } else {
            out += path[i++];
        }
    }
    return out;
}

bool hasFrameTokens(const std::string& path)
{
    size_t length = 0;
    int width = 1;
    for (size_t i = 0; i < path.size(); ++i)
        if (tokenAt(path, i, length, width))
            return true;
    return false;
}

namespace {

// Calls f on every path of the scene that frame tokens apply to.
template <class S, class F>
void forEachPath(S& scene, F f)
{
    for (auto& v : scene.volumes) {
        f(v.source.file);
        f(v.shader);
    }
    for (auto& g : scene.geometry)
        f(g.file);
    for (auto& l : scene.lights)
        f(l.map);  // an environment light's HDR map
    f(scene.camera.holdoutDepth.file);
    f(scene.output.file);
    f(scene.output.preview);
    f(scene.output.deep);
}

}  // namespace

Scene sceneAtFrame(const Scene& scene, int frame)
{
    Scene s = scene;
    s.render.frame = frame;
    evaluateAnimation(s);
    forEachPath(s, [frame](std::string& path) { path = expandFrameTokens(path, frame); });
    return s;
}

bool sceneHasFrameTokens(const Scene& scene)
{
    bool any = false;
    forEachPath(scene, [&any](const std::string& path) { any = any || hasFrameTokens(path); });
    return any;
}

namespace {

bool sameValue(float a, float b) { return a == b; }
bool sameValue(float3 a, float3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
bool sameValue(const Transform& a, const Transform& b) { return a.rowMajor() == b.rowMajor(); }

}  // namespace

void evaluateAnimation(Scene& s)
{
    const double frame = double(s.render.frame);
    Camera& c = s.camera;
    const double open = frame + double(c.shutterOpen), close = frame + double(c.shutterClose);
    const double centre = 0.5 * (open + close);
    const bool shutterOpen = c.shutterClose > c.shutterOpen;
    std::vector<std::string> moving;  // animated during the shutter but not blurred
    // The frames, relative to the frame, at which a value moving within the shutter is sampled:
    // open, every key strictly inside, close (motion.h: between them the keys' interpolation is
    // linear in time, so these knots reproduce it exactly).
    auto knotFrames = [&](const std::vector<double>& keyFrames, std::vector<double>& out) {
        out.push_back(open);
        for (double f : keyFrames)
            if (f > open && f < close)
                out.push_back(f);
        out.push_back(close);
    };
    auto at = [&](auto& value, auto& keys, double time, const std::string& what) {
        if (!keys.animated())
            return;
        value = evaluateKeys(keys, time);
        if (shutterOpen && !what.empty() &&
            !sameValue(evaluateKeys(keys, open), evaluateKeys(keys, close)))
            moving.push_back(what);
        keys = {};
    };
    const bool poseAnimated = c.fromKeys.animated() || c.toKeys.animated() || c.upKeys.animated();
    if (poseAnimated) {
        if (c.hasMotion)
            throw InputError("camera: both animation keys and a motion pose; give one");
        if (shutterOpen) {
            c.hasMotion = true;
            c.fromClose = c.fromKeys.animated() ? evaluateKeys(c.fromKeys, close) : c.from;
            c.toClose = c.toKeys.animated() ? evaluateKeys(c.toKeys, close) : c.to;
            c.upClose = c.upKeys.animated() ? evaluateKeys(c.upKeys, close) : c.up;
        }
        at(c.from, c.fromKeys, open, "");
        at(c.to, c.toKeys, open, "");
        at(c.up, c.upKeys, open, "");
        if (!shutterOpen)
            c.fromClose = c.from, c.toClose = c.to, c.upClose = c.up;
    }
    // The fov zooms within the shutter (camera.h): its knots are kept, at most
    // NB_CAMERA_FOV_KNOTS, and the static value is the shutter centre's (nimbus:camera's
    // matrices, tile culling's bounds take every knot).
    if (c.fovKeys.animated())
        c.fovShutterMotion = {};
    if (c.fovKeys.animated() && shutterOpen) {
        std::vector<double> frames;
        knotFrames(c.fovKeys.frames, frames);
        if (frames.size() > size_t(NB_CAMERA_FOV_KNOTS))
            throw InputError((s.sourcePath.empty() ? std::string() : s.sourcePath + ": ") + "camera.fov: " +
                             std::to_string(frames.size() - 2) + " keys within the shutter of frame " +
                             std::to_string(s.render.frame) + "; at most " + std::to_string(NB_CAMERA_FOV_KNOTS - 2) +
                             " can be motion-blurred");
        bool moves = false;  // a fov whose knots all agree holds still
        for (double f : frames) {
            c.fovShutterMotion.frames.push_back(f - frame);
            c.fovShutterMotion.values.push_back(evaluateKeys(c.fovKeys, f));
            moves |= !sameValue(c.fovShutterMotion.values.back(), c.fovShutterMotion.values.front());
        }
        if (!moves)
            c.fovShutterMotion = {};
    }
    at(c.fov, c.fovKeys, centre, "");
    // Lights and volume transforms move within the shutter (kernels/shared/motion.h): their
    // knots are kept, and the static value is the shutter centre's (shadow maps, light volumes
    // and bounds are built there).
    for (size_t i = 0; i < s.lights.size(); ++i) {
        Light& l = s.lights[i];
        Keys<float3>* keys[] = {&l.directionKeys, &l.positionKeys, &l.centerKeys, &l.normalKeys, &l.upKeys};
        // A frame's scene (no keys left) keeps the motion it was given: evaluating it again is
        // a fixed point.
        if (l.directionKeys.animated() || l.positionKeys.animated() || l.centerKeys.animated() ||
            l.normalKeys.animated() || l.upKeys.animated())
            l.shutterMotion = {};
        std::vector<double> all;
        bool animated = false;
        for (Keys<float3>* k : keys)
            if (k->animated()) {
                animated = true;
                all.insert(all.end(), k->frames.begin(), k->frames.end());
            }
        if (animated && shutterOpen) {
            std::sort(all.begin(), all.end());
            std::vector<double> frames;
            knotFrames(all, frames);
            frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
            for (double f : frames) {
                auto value = [&](const Keys<float3>& k, float3 still) { return k.animated() ? evaluateKeys(k, f) : still; };
                l.shutterMotion.frames.push_back(f - frame);
                l.shutterMotion.values.push_back({value(l.directionKeys, l.direction), value(l.positionKeys, l.position),
                                                  value(l.centerKeys, l.center), value(l.normalKeys, l.normal),
                                                  value(l.upKeys, l.up)});
            }
            bool moves = false;  // a light whose knots all agree holds still
            for (const Light::Pose& p : l.shutterMotion.values) {
                const Light::Pose& q = l.shutterMotion.values.front();
                moves |= !sameValue(p.direction, q.direction) || !sameValue(p.position, q.position) ||
                         !sameValue(p.center, q.center) || !sameValue(p.normal, q.normal) || !sameValue(p.up, q.up);
            }
            if (!moves)
                l.shutterMotion = {};
        }
        at(l.direction, l.directionKeys, centre, "");
        at(l.position, l.positionKeys, centre, "");
        at(l.center, l.centerKeys, centre, "");
        at(l.normal, l.normalKeys, centre, "");
        at(l.up, l.upKeys, centre, "");
    }
    for (size_t i = 0; i < s.volumes.size(); ++i) {
        Volume& v = s.volumes[i];
        if (v.transformKeys.animated())
            v.shutterMotion = {};
        if (v.transformKeys.animated() && shutterOpen) {
            std::vector<double> frames;
            knotFrames(v.transformKeys.frames, frames);
            bool moves = false;  // a transform whose knots all agree holds still
            for (double f : frames) {
                v.shutterMotion.frames.push_back(f - frame);
                v.shutterMotion.values.push_back(evaluateKeys(v.transformKeys, f));
                moves |= !sameValue(v.shutterMotion.values.back(), v.shutterMotion.values.front());
            }
            if (!moves)
                v.shutterMotion = {};
        }
        at(v.transform, v.transformKeys, centre, "");
    }
    for (size_t i = 0; i < s.geometry.size(); ++i)
        at(s.geometry[i].transform, s.geometry[i].transformKeys, centre,
           "geometry[" + std::to_string(i) + "].transform");
    if (!moving.empty()) {
        std::string list;
        for (const std::string& m : moving)
            list += (list.empty() ? "" : ", ") + m;
        logWarning("frame " + std::to_string(s.render.frame) + ": " + list +
                   (moving.size() == 1 ? " moves during the shutter but is not motion-blurred; it is"
                                       : " move during the shutter but are not motion-blurred; they are") +
                   " placed at the shutter's centre");
    }
}

}  // namespace nimbus
