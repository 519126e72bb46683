#include "FrameList.h"

#include "../core/Error.h"

#include <cctype>
#include <climits>
#include <set>

namespace nimbus {

namespace {

struct Parser {
    const std::string& spec;
    size_t pos = 0;

    [[noreturn]] void fail(const std::string& what) const
    {
        throw InputError("bad frame list '" + spec + "': " + what +
                         " (expected frames N, ranges A-B or A-BxS, separated by commas)");
    }
    bool at(char c) const { return pos < spec.size() && spec[pos] == c; }
    // An integer with an optional leading minus, within int.
    long long integer()
    {
        const size_t start = pos;
        if (at('-'))
            ++pos;
        const size_t digits = pos;
        long long v = 0;
        while (pos < spec.size() && std::isdigit(static_cast<unsigned char>(spec[pos]))) {
            v = v * 10 + (spec[pos++] - '0');
            if (v > (long long)INT_MAX + 1)
                fail("frame '" + spec.substr(start, pos - start) + "...' is out of range");
        }
        if (pos == digits)
            fail(pos < spec.size() ? "unexpected '" + std::string(1, spec[pos]) + "'"
                                   : "a number is missing at the end");
        v = spec[start] == '-' ? -v : v;
        if (v > INT_MAX || v < INT_MIN)
            fail("frame " + std::to_string(v) + " is out of range");
        return v;
    }
};

}  // namespace

std::vector<int> parseFrameList(const std::string& spec)
{
    Parser p{spec};
    std::vector<int> frames;
    std::set<int> seen;
    auto add = [&](long long f) {
        if (!seen.insert(int(f)).second)
            p.fail("frame " + std::to_string(f) + " is named twice");
        if (frames.size() == kMaxFrames)
            p.fail("more than " + std::to_string(kMaxFrames) + " frames");
        frames.push_back(int(f));
    };
    if (spec.empty())
        p.fail("no frames");
    while (true) {
        const long long a = p.integer();
        long long b = a, step = 1;
        if (p.at('-')) {
            ++p.pos;
            b = p.integer();
            if (b < a)
                p.fail("the range " + std::to_string(a) + "-" + std::to_string(b) + " runs backwards");
            if (p.at('x')) {
                ++p.pos;
                step = p.integer();
                if (step < 1)
                    p.fail("the step " + std::to_string(step) + " is under 1");
            }
        }
        if ((b - a) / step + 1 > (long long)kMaxFrames)
            p.fail("more than " + std::to_string(kMaxFrames) + " frames");
        for (long long f = a; f <= b; f += step)
            add(f);
        if (p.pos == spec.size())
            break;
        if (!p.at(','))
            p.fail("unexpected '" + std::string(1, spec[p.pos]) + "'");
        ++p.pos;
    }
    return frames;
}

}  // namespace nimbus
