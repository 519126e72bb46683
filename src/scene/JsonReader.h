// JsonReader.h: typed reading of one JSON object of a scene file, with key paths in errors.
//
// The scene parser reads each object through a JsonReader: every read names its key, a value of
// the wrong type fails with "<file>: <key.path>: expected ..., got <type>", and finish() fails on
// the first key nobody read ("unknown key"), as Mitsuba does: a misspelt key must not be
// silently ignored. The field() overloads have the same shape as JsonWriter's so that one
// visitor function lists an object's keys once for both directions (SceneJson.cpp).
#pragma once

#include "../core/Vec.h"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace nimbus {

// Converters from one JSON value; path names it in messages, file prefixes them.
struct JsonValue {
    const nlohmann::json& value;
    std::string path;
    const std::string& file;

    [[noreturn]] void fail(const std::string& what) const;
    [[noreturn]] void typeError(const std::string& expected) const;  // "expected X, got <type>"

    double number() const;  // finite
    float toFloat() const;  // finite and representable as a float
    int64_t integer(int64_t lo, int64_t hi) const;
    std::string string() const;
    bool boolean() const;
    float3 vec3() const;                   // array of 3 numbers
    Rgb rgb() const;                       // array of 3 numbers, or one number for grey
    void floats(float* out, int n) const;  // array of exactly n numbers
};

// Parses a JSON document like nlohmann::json::parse, but a key that appears twice in one object
// is an error: "<file>: <key.path>: duplicate key" (JSON leaves which one wins undefined; the
// parser kept the last, so a scene file's first value was silently ignored). Syntax errors throw
// nlohmann's parse_error as parse() does.
nlohmann::json parseJsonRejectingDuplicateKeys(const std::string& text, const std::string& file);

class JsonReader {
public:
    // Fails unless value is an object. path is the object's own key path ("" at the top level).
    JsonReader(const nlohmann::json& value, std::string path, const std::string& file);

    const std::string& file() const { return mFile; }
    std::string keyPath(const std::string& key) const { return mPath.empty() ? key : mPath + "." + key; }
    [[noreturn]] void fail(const std::string& key, const std::string& what) const;

    // The value of key, marked as read; nullptr if absent.
    const nlohmann::json* find(const std::string& key);
    JsonValue get(const std::string& key);  // fails if absent ("required key is missing")
    bool has(const std::string& key);

    // Reads key into out when present and leaves out unchanged (its default) when absent.
    void field(const std::string& key, float& out);
    void field(const std::string& key, double& out);
    void field(const std::string& key, int& out);
    void field(const std::string& key, uint32_t& out);
    void field(const std::string& key, std::string& out);
    void field(const std::string& key, bool& out);
    void field(const std::string& key, float3& out);  // a position or direction
    void rgb(const std::string& key, Rgb& out);
    void field(const std::string& key, std::vector<std::string>& out);  // a list of strings
    template <int N>
    void field(const std::string& key, float (&out)[N])
    {
        if (const nlohmann::json* v = find(key))
            JsonValue{*v, keyPath(key), mFile}.floats(out, N);
    }

    // Marks every key as read, for objects whose remaining keys the caller takes as a map.
    void markAllRead();
    // Fails on the first key not read. context follows "unknown key" (e.g. " for a point light").
    void finish(const std::string& context = "") const;

    const nlohmann::json& value() const { return mValue; }

private:
    const nlohmann::json& mValue;
    std::string mPath;
    const std::string& mFile;
    std::set<std::string> mRead;   // keys present and read
    std::set<std::string> mKnown;  // every key asked for, present or not: the "did you mean" list
};

// The JSON type name of a value as messages print it ("string", "array", "number", ...).
std::string jsonTypeName(const nlohmann::json& value);

}  // namespace nimbus
