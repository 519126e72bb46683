#include "FrameTokens.h"

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
    f(scene.camera.holdoutDepth.file);
    f(scene.output.file);
    f(scene.output.preview);
}

}  // namespace

Scene sceneAtFrame(const Scene& scene, int frame)
{
    Scene s = scene;
    s.render.frame = frame;
    forEachPath(s, [frame](std::string& path) { path = expandFrameTokens(path, frame); });
    return s;
}

bool sceneHasFrameTokens(const Scene& scene)
{
    bool any = false;
    forEachPath(scene, [&any](const std::string& path) { any = any || hasFrameTokens(path); });
    return any;
}

}  // namespace nimbus
