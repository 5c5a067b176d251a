// Shared test fixture: studies built in code (no study file), one helper per set-up, so that the
// tests that build a bin, a two-layer soil, a plate or the paper's penetrometer build it alike and
// say in their own code only what they change beyond it.
#pragma once

#include "demfem/study/study.hpp"

#include <numbers>
#include <string>
#include <utility>

namespace demfem::support {

// A study of `kind` named `name` on a `length_m` x `width_m` bin filled `fill_m` deep (m); every
// other value the study default.
inline study::Study binStudy(const std::string& name, study::StudyKind kind, double length_m, double width_m, double fill_m) {
  study::Study s;
  s.name = name;
  s.kind = kind;
  s.soil.bin_length_m = length_m;
  s.soil.bin_width_m = width_m;
  s.soil.fill_height_m = fill_m;
  return s;
}

// Two particle layers of one glass-bead-like material (2600 kg/m^3, E 11.2 GPa, nu 0.3, yield
// 588 kPa): "top" down to `top_bottom_m`, "deep" below it to the fill; the bin of "steel" (7933
// kg/m^3, E 79 GPa, nu 0.3). The interactions are the caller's.
inline void useTopAndDeepLayers(study::Soil& soil, double top_bottom_m) {
  soil.materials = {{"top", 2600, 1.12e10, 0.3, 5.88e5}, {"deep", 2600, 1.12e10, 0.3, 5.88e5}, {"steel", 7933, 7.9e10, 0.3, 0}};
  soil.bin_material = "steel";
  soil.layers = {{"top", 0, top_bottom_m}, {"deep", top_bottom_m, soil.fill_height_m}};
}

// The built-in backend tests' bin: 120 x 120 mm with 40 mm of soil, top and deep layers split at
// 10 mm depth, quick.json-like laws between every pair of layers and with the steel tool, settled
// below 1e-5 J.
inline study::Study twoLayerTestBin(const std::string& name, study::StudyKind kind) {
  study::Study s = binStudy(name, kind, 0.12, 0.12, 0.04);
  auto& soil = s.soil;
  useTopAndDeepLayers(soil, 0.01);
  for (const auto& [a, b] : {std::pair{"top", "top"}, {"top", "deep"}, {"deep", "deep"}})
    soil.interactions.push_back({a, b, 0.6, 0.3, 0.1, 3e4});
  for (const char* m : {"top", "deep"}) soil.interactions.push_back({m, "steel", 0.6, 0.3, 0.1, 0});
  soil.settle_kinetic_energy_J = 1e-5;
  return s;
}

// The built-in DEM at 0.1 of the stiffest spring's critical step on one thread (two threads of one
// run wait for each other on a loaded machine); the FEM step `fem_dt_s` (s).
inline void useBuiltinStep(study::Study& s, double fem_dt_s) {
  s.fem.dt_s = fem_dt_s;
  s.dem.criterion = study::TimeStepCriterion::StiffestSpring;
  s.dem.dt_fraction = 0.1;
  s.dem.threads = 1;
}

// The tool a `length_m` x `width_m` x `thickness_m` plate (m).
inline void usePlate(study::Tool& tool, double length_m, double width_m, double thickness_m) {
  tool.geometry.kind = study::GeometryKind::Plate;
  tool.geometry.length_m = length_m;
  tool.geometry.width_m = width_m;
  tool.geometry.thickness_m = thickness_m;
}

// The tool the paper's penetrometer (Section 2.10.3): a 5 cm^2 cone of 60 deg on a shaft, cone and
// shaft `length_m` long (m).
inline void usePaperCone(study::Tool& tool, double length_m) {
  tool.geometry.kind = study::GeometryKind::Cone;
  tool.geometry.cone_area_m2 = 5e-4;
  tool.geometry.cone_angle_rad = std::numbers::pi / 3;
  tool.geometry.length_m = length_m;
}

}  // namespace demfem::support
