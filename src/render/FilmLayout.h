// FilmLayout.h: which AOVs an integrator's film holds, in output order, and how the film is sized
// from the camera. The names are the contract of Film.h; the terms come from IntegratorTraits.
#pragma once

#include "Film.h"
#include "Integrator.h"

#include <string>
#include <vector>

namespace nimbus {

// "beauty", the integrator's terms, "alpha", "depth", its data AOVs, then "light_<name>" per light.
std::vector<std::string> aovNames(const Scene& scene, const IntegratorTraits& traits);

// Sizes the film for the camera (crop = data window) and adds the integrator's AOVs, or with
// outputAovsOnly the beauty and those scene.output.aovs names (all where it is empty).
void setupFilm(Film& film, const Scene& scene, const IntegratorTraits& traits, bool outputAovsOnly = false);

// The AOV name of light i ("light_<name>", or its index when unnamed).
std::string lightAovName(const Light& light, size_t i);

}  // namespace nimbus
