#include "Film.h"

namespace nimbus {

Aov& Film::add(const std::string& name, int channels, bool isData)
{
    if (Aov* existing = find(name))
        return *existing;
    Aov aov;
    aov.name = name;
    aov.channels = channels;
    aov.isData = isData;
    aov.pixels.assign(size_t(width) * height * channels, 0.0f);
    aovs.push_back(std::move(aov));
    return aovs.back();
}

Aov* Film::find(const std::string& name)
{
    for (auto& a : aovs)
        if (a.name == name)
            return &a;
    return nullptr;
}

const Aov* Film::find(const std::string& name) const
{
    for (auto& a : aovs)
        if (a.name == name)
            return &a;
    return nullptr;
}

}  // namespace nimbus
