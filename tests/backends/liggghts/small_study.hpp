// A small study for the liggghts backend tests: one soil layer, a steel bin, a steel plate tool,
// LIGGGHTS-compatible contact laws (plain hooke, tangential history, cdt rolling friction).
#pragma once

#include "demfem/study/study.hpp"
#include "support/study_in_code.hpp"

namespace demfem::liggghts::testing {

inline study::Study smallStudy() {
  study::Study s = support::binStudy("liggghts-small", study::StudyKind::DemOnly, 0.16, 0.08, 0.04);
  auto& soil = s.soil;
  soil.diameter_min_m = 0.0095;
  soil.diameter_max_m = 0.0105;
  soil.materials = {{"soil", 2600, 5e6, 0.3, 0},
                    {"bin_steel", 7850, 2e8, 0.3, 0},
                    {"tool_steel", 7850, 2e8, 0.3, 0}};
  soil.bin_material = "bin_steel";
  soil.layers = {{"soil", 0.0, 0.04}};
  soil.interactions = {{"soil", "soil", 0.5, 0.5, 0.1, 0.0},
                       {"soil", "bin_steel", 0.5, 0.4, 0.05, 0.0},
                       {"soil", "tool_steel", 0.5, 0.4, 0.05, 0.0}};
  soil.contact.normal = study::NormalModel::Hooke;
  soil.contact.cohesion = study::CohesionModel::None;
  soil.contact.rolling = study::RollingModel::Cdt;
  soil.contact.tangential_history = true;
  soil.contact.characteristic_velocity_m_s = 0.5;
  soil.settle_kinetic_energy_J = 1e-6;
  soil.deposition_backend = "liggghts";  // these tests exercise LIGGGHTS' own deposition
  study::Tool tool;
  tool.name = "tool";
  tool.dem_material = "tool_steel";
  support::usePlate(tool, 0.1, 0.04, 0.003);
  tool.geometry.keypoint_spacing_m = 0.01;
  tool.motion.depth_m = 0.02;
  tool.motion.start_z_m = 0.0;
  tool.motion.center_x_m = 0.04;  // the bin's centre line
  tool.motion.velocity_m_s = 0.1;
  tool.motion.stroke_m = 0.1;
  s.tools = {tool};
  s.dem.backend = "liggghts";
  s.dem.dt_fraction = 0.2;
  return s;
}

}  // namespace demfem::liggghts::testing
