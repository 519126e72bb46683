// OneLine.h: an error message as one line, whatever it quotes.
//
// Messages quote what the user wrote (a --set assignment, a file name, a JSON string or key),
// and that may hold a newline: `--set $'li{\n...'` printed a two-line error (fuzz_scene's first
// finding, issue 18 item 5). The places a message leaves nimbus (the CLI's error line, the C
// ABI's last error and session message) pass it through oneLine.
#pragma once

#include <cstdio>
#include <string>

namespace nimbus {

// Control characters written as escapes (\n, \r, \t, \xNN); everything else (UTF-8 included)
// as it is. Idempotent: an escaped message is left as it is. asciiOnly: bytes above 0x7e as \xNN
// too (a line of a binary file quoted in a message, which need not be UTF-8).
inline std::string oneLine(const std::string& text, bool asciiOnly = false)
{
    std::string out;
    out.reserve(text.size());
    for (unsigned char c : text) {
        if (c >= 0x20 && c != 0x7f && !(asciiOnly && c > 0x7f)) {
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

}  // namespace nimbus
