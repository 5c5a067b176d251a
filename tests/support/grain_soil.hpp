// Shared test fixture: a soil built in code with one particle material "grain" and one wall
// material "steel", every interaction with the same coefficients (the built-in DEM's unit tests and
// the settled-soil file tests).
#pragma once

#include "demfem/study/study.hpp"

#include <utility>

namespace demfem::support {

struct SoilParameters {
  double density = 2000;        // kg/m^3
  double yield = 1e6;           // Pa: K1 = 5 R* Y
  double restitution = 0.5;
  double friction = 0.5;
  double rolling_friction = 0;
  double cohesion = 0;          // J/m^3
  study::ContactModel model{};
};

// The bin, fill and particle sizes are the study defaults; one layer of grain fills the bin.
inline study::Soil makeSoil(const SoilParameters& p) {
  study::Soil soil;
  soil.materials = {{"grain", p.density, 5e7, 0.25, p.yield}, {"steel", 7850, 2e11, 0.3, p.yield}};
  soil.bin_material = "steel";
  soil.layers = {{"grain", 0, soil.fill_height_m}};
  for (const auto& [a, b] : {std::pair{"grain", "grain"}, {"grain", "steel"}, {"steel", "steel"}})
    soil.interactions.push_back({a, b, p.restitution, p.friction, p.rolling_friction, p.cohesion});
  soil.contact = p.model;
  return soil;
}

}  // namespace demfem::support
