// SceneOverrides.cpp: the CLI's "--set key.path=value", applied to the scene document before it
// is parsed, so an overridden value meets exactly the checks a value in the file meets.
// "key[+]" appends an entry to a list (creating the list where the document has none), e.g.
// --set 'lights[+]={"type": "point", "position": [0, 2, 0], "intensity": 5}'.
#include "SceneJson.h"

#include "SceneValidate.h"

#include "../core/Utf8.h"

#include <nlohmann/json.hpp>

#include <cctype>
#include <vector>

namespace nimbus {

using nlohmann::json;

namespace {

// An object key, or a list index when isIndex is set (append: a new entry at the list's end).
struct PathStep {
    std::string key;
    size_t index = 0;
    bool isIndex = false;
    bool append = false;
};

std::string describe(const json& node)
{
    if (node.is_null())
        return "missing";
    if (node.is_object())
        return "an object";
    if (node.is_array())
        return "a list";
    if (node.is_boolean())
        return "a boolean";
    return std::string("a ") + node.type_name();
}

class Override {
public:
    Override(const std::string& assignment, const std::string& sourcePath) : mText(assignment), mSourcePath(sourcePath)
    {
    }

    [[noreturn]] void fail(const std::string& what) const
    {
        throwSceneError(mSourcePath, "", "--set '" + mText + "': " + what);
    }

    // "lights[0].irradiance" -> "lights", 0, "irradiance".
    std::vector<PathStep> parsePath(const std::string& path) const
    {
        std::vector<PathStep> steps;
        size_t i = 0;
        while (i < path.size()) {
            size_t end = path.find_first_of(".[]", i);
            std::string key = path.substr(i, end == std::string::npos ? std::string::npos : end - i);
            if (key.empty())
                fail("expected a key name at character " + std::to_string(i + 1) + " of '" + path + "'");
            steps.push_back({key, 0, false});
            i = end == std::string::npos ? path.size() : end;
            while (i < path.size() && path[i] == '[') {
                size_t close = path.find(']', i);
                std::string digits = path.substr(i + 1, close == std::string::npos ? std::string::npos : close - i - 1);
                if (close != std::string::npos && digits == "+") {
                    steps.push_back({"", 0, true, true});
                    i = close + 1;
                    continue;
                }
                bool ok = close != std::string::npos && !digits.empty() && digits.size() < 10;
                for (char c : digits)
                    ok = ok && std::isdigit(static_cast<unsigned char>(c));
                if (!ok)
                    fail("expected a list index [0], [1], ... or [+] (append) in '" + path + "'");
                steps.push_back({"", size_t(std::stoul(digits)), true});
                i = close + 1;
            }
            if (i < path.size()) {
                if (path[i] != '.' || i + 1 == path.size())
                    fail("unexpected '" + std::string(1, path[i]) + "' in '" + path + "'");
                ++i;
            }
        }
        return steps;
    }

    void apply(json& document) const
    {
        size_t eq = mText.find('=');
        if (eq == std::string::npos)
            fail("expected key.path=value");
        std::string path = mText.substr(0, eq);
        if (path.empty())
            fail("the key path before '=' is empty");
        std::vector<PathStep> steps = parsePath(path);

        // JSON if it parses (numbers, arrays, true), else the text itself (wkb, out/a.exr).
        std::string text = mText.substr(eq + 1);
        json value = json::parse(text, nullptr, false);
        if (value.is_discarded()) {
            // The scene format is JSON, whose strings are UTF-8 text.
            const size_t bad = firstInvalidUtf8(text);
            if (bad < text.size())  // the key alone: the value's bytes are not text to print
                throwSceneError(mSourcePath, "", "--set '" + path + "=...': the value is not UTF-8 text (byte " +
                                                     std::to_string(bad + 1) + " of it)");
            value = text;
        }

        json* node = &document;
        std::string walked;
        for (const PathStep& step : steps) {
            if (!step.isIndex) {
                // A missing object on the way is created: render.spp works on a file without "render".
                if (node->is_null())
                    *node = json::object();
                if (!node->is_object())
                    fail("'" + walked + "' is " + describe(*node) + ", not an object");
                node = &(*node)[step.key];
                walked += (walked.empty() ? "" : ".") + step.key;
            } else if (step.append) {
                if (node->is_null())
                    *node = json::array();
                if (!node->is_array())
                    fail("'" + walked + "' is " + describe(*node) + ", not a list");
                node->push_back(json());
                walked += "[" + std::to_string(node->size() - 1) + "]";
                node = &node->back();
            } else {
                size_t index = step.index;
                if (!node->is_array())
                    fail("'" + walked + "' is " + describe(*node) + ", not a list");
                if (index >= node->size())
                    fail("'" + walked + "' has " + std::to_string(node->size()) + " entries, no [" +
                         std::to_string(index) + "]");
                node = &(*node)[index];
                walked += "[" + std::to_string(index) + "]";
            }
        }
        *node = value;
    }

private:
    const std::string& mText;
    const std::string& mSourcePath;
};

}  // namespace

void applyOverrides(json& document, const std::vector<std::string>& overrides, const std::string& sourcePath)
{
    for (const std::string& assignment : overrides)
        Override(assignment, sourcePath).apply(document);
}

}  // namespace nimbus
