// Error.h: the error types library code throws; the CLI and the C ABI turn them into one line
// and an exit or error code. Library code never terminates the process (STYLE rule 8).
#pragma once

#include <cstdio>
#include <stdexcept>
#include <string>

namespace nimbus {

// The message as one line: control characters are written as escapes (\n, \r, \t, \xNN).
// Messages quote what the user wrote (a --set assignment, a file name, a JSON string), and that
// may hold a newline: the CLI's error must stay one line (a fuzz finding, issue 18 item 5).
// Idempotent: an escaped message is left as it is.
inline std::string oneLine(const std::string& text)
{
    std::string out;
    out.reserve(text.size());
    for (unsigned char c : text) {
        if (c >= 0x20 && c != 0x7f) {
            out += char(c);
        } else if (c == '\n') {
            out += "\\n";
        } else if (c == '\r') {
            out += "\\r";
        } else if (c == '\t') {
            out += "\\t";
        } else {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", unsigned(c));
            out += hex;
        }
    }
    return out;
}

// A render failure: something went wrong that is not the user's input (exit code 1).
class Error : public std::runtime_error {
public:
    explicit Error(const std::string& what) : std::runtime_error(oneLine(what)) {}
    explicit Error(const char* what) : Error(std::string(what)) {}
};

// Bad user input: a missing file or grid, bad JSON, an unknown key, a value out of range
// (exit code 2). The message names the file and the key path.
class InputError : public Error {
public:
    using Error::Error;
};

}  // namespace nimbus
