// Small soils built in code for the builtin DEM tests: one particle material "grain" and one wall
// material "steel", all interactions with the same coefficients.
#pragma once

#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/study/study.hpp"

#include <numbers>

namespace demfem::builtin::testing {

struct SoilParameters {
  double density = 2000;        // kg/m^3
  double yield = 1e6;           // Pa: K1 = 5 R* Y
  double restitution = 0.5;
  double friction = 0.5;
  double rolling_friction = 0;
  double cohesion = 0;          // J/m^3
  study::ContactModel model{};
};

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

inline Domain box(double half) { return Domain{{-half, -half, -half}, {half, half, half}}; }

inline double sphereMass(double density, double radius) {
  return density * 4.0 / 3.0 * std::numbers::pi * radius * radius * radius;
}

}  // namespace demfem::builtin::testing
