#include "FilmLayout.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

std::string lightAovName(const Light& light, size_t i)
{
    return "light_" + (light.name.empty() ? std::to_string(i) : light.name);
}

std::vector<std::string> aovNames(const Scene& scene, const IntegratorTraits& traits)
{
    std::vector<std::string> names = {"beauty"};
    names.insert(names.end(), traits.terms.begin(), traits.terms.end());
    names.push_back("alpha");
    names.push_back("depth");
    names.insert(names.end(), traits.dataAovs.begin(), traits.dataAovs.end());
    for (size_t i = 0; i < scene.lights.size(); ++i)
        names.push_back(lightAovName(scene.lights[i], i));
    return names;
}

void setupFilm(Film& film, const Scene& scene, const IntegratorTraits& traits, bool outputAovsOnly)
{
    const Camera& c = scene.camera;
    film.width = c.width;
    film.height = c.height;
    film.x0 = std::max(0, int(std::floor(c.crop[0] * c.width)));
    film.x1 = std::min(c.width, int(std::ceil(c.crop[1] * c.width)));
    film.y0 = std::max(0, int(std::floor(c.crop[2] * c.height)));
    film.y1 = std::min(c.height, int(std::ceil(c.crop[3] * c.height)));
    // A plane is 1-4 floats per pixel, allocated and zeroed before the first ray: where only the
    // output's are wanted, no others (the beauty is always there: every integrator writes it).
    const auto& wanted = scene.output.aovs;
    for (const std::string& name : aovNames(scene, traits)) {
        if (outputAovsOnly && name != "beauty" && !wanted.empty() &&
            std::find(wanted.begin(), wanted.end(), name) == wanted.end())
            continue;
        bool data = name == "alpha" || name == "depth" ||
                    std::find(traits.dataAovs.begin(), traits.dataAovs.end(), name) != traits.dataAovs.end();
        film.add(name, name == "beauty" ? 4 : (data ? 1 : 3), data);
    }
}

}  // namespace nimbus
