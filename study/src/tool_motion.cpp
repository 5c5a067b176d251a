#include "demfem/study/tool_motion.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace demfem::study {

Point3 LinearMotion::at(double t_s) const {
  Point3 p{};
  for (std::size_t c = 0; c < 3; ++c) p[c] = origin_m[c] + velocity_m_s[c] * (t_s - t0_s);
  return p;
}

Point3 ToolMotionPlan::positionAt(double t_s) const {
  const double insertion_end = static_cast<double>(insertion_steps) * dt_s;
  const double drag_end = static_cast<double>(totalSteps()) * dt_s;
  if (t_s <= 0) return start_m;
  if (t_s <= insertion_end || drag_steps == 0) return insertion.at(std::min(t_s, insertion_end));
  return drag.at(std::min(t_s, drag_end));
}

double demStepDividing(double dem_dt_s, double fem_dt_s) {
  if (!(fem_dt_s > 0)) return dem_dt_s;
  return fem_dt_s / std::ceil(fem_dt_s / dem_dt_s - 1e-9);
}

ToolMotionPlan planToolMotion(const Study& study, const Tool& tool) {
  const std::string what = "tool '" + tool.name + "' of study '" + study.name + "'";
  if (!hasSoil(study.kind)) throw std::invalid_argument(what + ": the study's kind moves no tool through soil");
  const auto& m = tool.motion;
  const bool cone = tool.geometry.kind == GeometryKind::Cone;
  const double insertion_speed = cone ? m.velocity_m_s : m.insertion_velocity_m_s;
  if (!(study.fem.dt_s > 0)) throw std::invalid_argument(what + ": fem.dt_s must be > 0");
  if (!(insertion_speed > 0) || !(m.velocity_m_s > 0) || (!cone && !(m.stroke_m > 0)))
    throw std::invalid_argument(what + ": motion velocities and stroke must be > 0");
  ToolMotionPlan plan;
  plan.dt_s = study.fem.dt_s;
  const double clearance = study.soil.diameter_max_m;
  const double top = study.soil.fill_height_m;
  plan.depth_y_m = top - m.depth_m;
  plan.start_m = {m.center_x_m, top + clearance, cone ? m.start_z_m : m.start_z_m - 0.5 * tool.geometry.thickness_m};
  const double travel = m.depth_m + clearance;
  // The fewest whole steps at which the insertion is not faster than the study's speed.
  plan.insertion_steps = std::max<std::int64_t>(
      1, static_cast<std::int64_t>(std::ceil(travel / insertion_speed / plan.dt_s - 1e-9)));
  const double insertion_time = static_cast<double>(plan.insertion_steps) * plan.dt_s;
  plan.insertion = {plan.start_m, {0, -travel / insertion_time, 0}, 0};
  plan.drag_steps = cone ? 0 : std::max<std::int64_t>(1, std::llround(m.stroke_m / m.velocity_m_s / plan.dt_s));
  plan.drag = {{plan.start_m[0], plan.depth_y_m, plan.start_m[2]}, {0, 0, cone ? 0.0 : m.velocity_m_s}, insertion_time};
  return plan;
}

}  // namespace demfem::study
