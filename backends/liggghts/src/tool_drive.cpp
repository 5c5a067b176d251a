#include "demfem/backends/liggghts/tool_drive.hpp"

namespace demfem::liggghts {

void setToolVelocity(adapter::CouplingApi& dem, const std::string& tool, const std::array<double, 3>& velocity_m_s) {
  auto m = dem.rigidMotion(tool);
  const double t = dem.time();
  for (std::size_t c = 0; c < 3; ++c) m.origin_m[c] += m.velocity_m_s[c] * (t - m.t0_s);
  m.velocity_m_s = velocity_m_s;
  m.t0_s = t;
  dem.setRigidMotion(tool, m);
}

void insertAndStartDrag(adapter::CouplingApi& dem, const study::Study& study, const study::Tool& tool) {
  const auto m = dem.rigidMotion(tool.name);
  const double tip_y = m.origin_m[1] + m.velocity_m_s[1] * (dem.time() - m.t0_s);
  const double travel = tip_y - (study.soil.fill_height_m - tool.motion.depth_m);
  if (travel > 0) {
    setToolVelocity(dem, tool.name, {0, -tool.motion.insertion_velocity_m_s, 0});
    dem.simulate(travel / tool.motion.insertion_velocity_m_s);
  }
  setToolVelocity(dem, tool.name, {0, 0, tool.motion.velocity_m_s});
}

}  // namespace demfem::liggghts
