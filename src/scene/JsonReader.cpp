#include "JsonReader.h"

#include "SceneValidate.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

namespace nimbus {

using nlohmann::json;

std::string jsonTypeName(const json& value)
{
    if (value.is_array())
        return "an array of " + std::to_string(value.size());
    return value.type_name();
}

namespace {

// Where the parser is: one frame per open object or array, for the key set and the key path.
struct ParseFrame {
    bool array = false;
    size_t index = 0;  // array: the element being parsed
    std::string key;   // object: the key whose value is being parsed
    std::set<std::string> keys;
};

std::string framePath(const std::vector<ParseFrame>& frames, const std::string& last)
{
    std::string path;
    for (size_t i = 0; i + 1 < frames.size(); ++i)
        path +=
            frames[i].array ? "[" + std::to_string(frames[i].index) + "]" : (path.empty() ? "" : ".") + frames[i].key;
    return path + (path.empty() ? "" : ".") + last;
}

}  // namespace

json parseJsonRejectingDuplicateKeys(const std::string& text, const std::string& file)
{
    std::vector<ParseFrame> frames;
    auto elementDone = [&] {
        if (!frames.empty() && frames.back().array)
            ++frames.back().index;
    };
    json::parser_callback_t callback = [&](int, json::parse_event_t event, json& parsed) {
        switch (event) {
        case json::parse_event_t::object_start:
        case json::parse_event_t::array_start:
            frames.push_back(ParseFrame{event == json::parse_event_t::array_start, 0, {}, {}});
            break;
        case json::parse_event_t::key: {
            ParseFrame& top = frames.back();
            top.key = parsed.get<std::string>();
            if (!top.keys.insert(top.key).second)
                throwSceneError(file, framePath(frames, top.key),
                                "duplicate key (each key may appear once in an object)");
            break;
        }
        case json::parse_event_t::object_end:
        case json::parse_event_t::array_end:
            frames.pop_back();
            elementDone();
            break;
        case json::parse_event_t::value: elementDone(); break;
        }
        return true;
    };
    return json::parse(text, callback);
}

void JsonValue::fail(const std::string& what) const
{
    throwSceneError(file, path, what);
}

void JsonValue::typeError(const std::string& expected) const
{
    fail("expected " + expected + ", got " + jsonTypeName(value));
}

double JsonValue::number() const
{
    if (!value.is_number())
        typeError("a number");
    double v = value.get<double>();
    if (!std::isfinite(v))
        fail("must be a finite number");
    return v;
}

float JsonValue::toFloat() const
{
    double v = number();
    if (std::fabs(v) > double(std::numeric_limits<float>::max()))
        fail("out of range for a 32-bit float, got " + value.dump());
    return float(v);
}

int64_t JsonValue::integer(int64_t lo, int64_t hi) const
{
    int64_t v = 0;
    if (value.is_number_unsigned()) {
        uint64_t u = value.get<uint64_t>();
        v = u > uint64_t(std::numeric_limits<int64_t>::max()) ? std::numeric_limits<int64_t>::max() : int64_t(u);
    } else if (value.is_number_integer()) {
        v = value.get<int64_t>();
    } else if (value.is_number_float()) {
        // Writers such as Python's json emit 16.0 for an integer-valued float; accept it.
        double d = value.get<double>();
        if (!(std::floor(d) == d) || std::fabs(d) > 9.0e18)
            fail("expected an integer, got " + value.dump());
        v = int64_t(d);
    } else {
        typeError("an integer");
    }
    if (v < lo || v > hi)
        fail("must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + value.dump());
    return v;
}

std::string JsonValue::string() const
{
    if (!value.is_string())
        typeError("a string");
    return value.get<std::string>();
}

bool JsonValue::boolean() const
{
    if (!value.is_boolean())
        typeError("true or false");
    return value.get<bool>();
}

void JsonValue::floats(float* out, int n) const
{
    if (!value.is_array() || int(value.size()) != n)
        typeError("an array of " + std::to_string(n) + " numbers");
    for (int i = 0; i < n; ++i)
        out[i] = JsonValue{value[size_t(i)], path + "[" + std::to_string(i) + "]", file}.toFloat();
}

float3 JsonValue::vec3() const
{
    float f[3];
    floats(f, 3);
    return make_float3(f[0], f[1], f[2]);
}

Rgb JsonValue::rgb() const
{
    if (value.is_number())
        return splat(toFloat());
    if (!value.is_array() || value.size() != 3)
        typeError("an RGB array of 3 numbers or a number");
    return vec3();
}

JsonReader::JsonReader(const json& value, std::string path, const std::string& file)
    : mValue(value), mPath(std::move(path)), mFile(file)
{
    if (!value.is_object())
        JsonValue{value, mPath, mFile}.typeError("an object");
}

void JsonReader::fail(const std::string& key, const std::string& what) const
{
    throwSceneError(mFile, keyPath(key), what);
}

const json* JsonReader::find(const std::string& key)
{
    mKnown.insert(key);
    auto it = mValue.find(key);
    if (it == mValue.end())
        return nullptr;
    mRead.insert(key);
    return &*it;
}

bool JsonReader::has(const std::string& key)
{
    mKnown.insert(key);
    return mValue.contains(key);
}

JsonValue JsonReader::get(const std::string& key)
{
    const json* v = find(key);
    if (!v)
        fail(key, "required key is missing");
    return JsonValue{*v, keyPath(key), mFile};
}

void JsonReader::field(const std::string& key, float& out)
{
    if (const json* v = find(key))
        out = JsonValue{*v, keyPath(key), mFile}.toFloat();
}

void JsonReader::field(const std::string& key, double& out)
{
    if (const json* v = find(key))
        out = JsonValue{*v, keyPath(key), mFile}.number();
}

void JsonReader::field(const std::string& key, int& out)
{
    if (const json* v = find(key))
        out = int(JsonValue{*v, keyPath(key), mFile}.integer(std::numeric_limits<int>::min(),
                                                             std::numeric_limits<int>::max()));
}

void JsonReader::field(const std::string& key, uint32_t& out)
{
    if (const json* v = find(key))
        out = uint32_t(JsonValue{*v, keyPath(key), mFile}.integer(0, std::numeric_limits<uint32_t>::max()));
}

void JsonReader::field(const std::string& key, std::string& out)
{
    if (const json* v = find(key))
        out = JsonValue{*v, keyPath(key), mFile}.string();
}

void JsonReader::field(const std::string& key, bool& out)
{
    if (const json* v = find(key))
        out = JsonValue{*v, keyPath(key), mFile}.boolean();
}

void JsonReader::field(const std::string& key, float3& out)
{
    if (const json* v = find(key))
        out = JsonValue{*v, keyPath(key), mFile}.vec3();
}

void JsonReader::rgb(const std::string& key, Rgb& out)
{
    if (const json* v = find(key))
        out = JsonValue{*v, keyPath(key), mFile}.rgb();
}

void JsonReader::field(const std::string& key, std::vector<std::string>& out)
{
    const json* v = find(key);
    if (!v)
        return;
    JsonValue list{*v, keyPath(key), mFile};
    if (!v->is_array())
        list.typeError("a list of strings");
    out.clear();
    for (size_t i = 0; i < v->size(); ++i)
        out.push_back(JsonValue{(*v)[i], list.path + "[" + std::to_string(i) + "]", mFile}.string());
}

void JsonReader::markAllRead()
{
    for (const auto& item : mValue.items())
        mRead.insert(item.key());
}

namespace {

// Levenshtein distance, for "did you mean" on a misspelt key.
size_t editDistance(const std::string& a, const std::string& b)
{
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j)
        row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diag = row[0];
        row[0] = i;
        for (size_t j = 1; j <= b.size(); ++j) {
            size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diag = up;
        }
    }
    return row[b.size()];
}

}  // namespace

void JsonReader::finish(const std::string& context) const
{
    for (const auto& item : mValue.items()) {
        if (mRead.count(item.key()))
            continue;
        std::string best;
        size_t bestDistance = 3;
        for (const std::string& known : mKnown) {
            size_t d = editDistance(item.key(), known);
            if (d < bestDistance)
                best = known, bestDistance = d;
        }
        std::string hint = best.empty() ? "" : " (did you mean '" + best + "'?)";
        fail(item.key(), "unknown key" + context + hint);
    }
}

}  // namespace nimbus
