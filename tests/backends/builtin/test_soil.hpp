// Small soils built in code for the builtin DEM tests (support/grain_soil.hpp: one particle material
// "grain" and one wall material "steel"), their box and particle masses.
#pragma once

#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/study/study.hpp"
#include "support/grain_soil.hpp"

#include <numbers>

namespace demfem::builtin::testing {

using support::makeSoil;  // support/grain_soil.hpp
using support::SoilParameters;

inline Domain box(double half) { return Domain{{-half, -half, -half}, {half, half, half}}; }

inline double sphereMass(double density, double radius) {
  return density * 4.0 / 3.0 * std::numbers::pi * radius * radius * radius;
}

}  // namespace demfem::builtin::testing
