#include "Film.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace nimbus {

Aov& Film::add(const std::string& name, int channels, bool isData)
{
    if (Aov* existing = find(name))
        return *existing;
    Aov aov;
    aov.name = name;
    aov.channels = channels;
    aov.isData = isData;
    // Zeroed in parallel: the first touch of a fresh plane is page faults (BulkAllocator.h).
    aov.pixels.resize(size_t(width) * height * channels);
    float* p = aov.pixels.data();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, aov.pixels.size(), size_t(1) << 16),
                      [&](const tbb::blocked_range<size_t>& r) { std::fill(p + r.begin(), p + r.end(), 0.0f); });
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

const FilmValue* Film::meta(const std::string& key) const
{
    for (auto& [name, value] : metadata)
        if (name == key)
            return &value;
    return nullptr;
}

void Film::set(const std::string& key, FilmValue value)
{
    for (auto& [name, existing] : metadata)
        if (name == key) {
            existing = std::move(value);
            return;
        }
    metadata.push_back({key, std::move(value)});
}

}  // namespace nimbus
