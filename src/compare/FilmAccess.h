// FilmAccess.h: the reads of a Film that the `nimbus compare` files share (an AOV that must be
// there, a pixel's luminance, the path tracer's sample count). Private to src/compare.
#pragma once

#include "../core/Error.h"
#include "../render/Film.h"

#include <cstdlib>
#include <string>

namespace nimbus {

inline const Aov& requireAov(const Film& f, const std::string& name)
{
    const Aov* a = f.find(name);
    if (!a)
        throw Error("compare: the film has no AOV '" + name + "'");
    return *a;
}

// Luminance of an AOV's first three channels.
inline float lum(const Aov& a, size_t i)
{
    const float* p = a.pixels.data() + i * size_t(a.channels);
    return 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
}

inline long long sppOf(const Film& f)
{
    const FilmValue* spp = f.meta("pathtrace_spp");
    const std::string* text = spp ? std::get_if<std::string>(spp) : nullptr;
    return text ? std::atoll(text->c_str()) : 0;
}

}  // namespace nimbus
