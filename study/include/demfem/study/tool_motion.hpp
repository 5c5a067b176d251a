// The motion of a tool through the soil bin during a run (paper Section 2.9, Fig. 4): the one plan
// that the FEM client (fem/coupled_driver.hpp) drives and every DEM backend starts from
// (adapter/coupling_api.hpp, "After construction"). Computed once from the study, a plain value.
//
// Contract
// - Units SI, bin frame (study.hpp): x across, y up, z along the bin. A tool's local origin is its
//   tip (local y = 0), centred in x and z (study.hpp), so `origin` below is where the tip centre is.
// - Start pose (time 0 of the plan, at rest): x = motion.center_x_m, tip one largest particle
//   diameter (soil.diameter_max_m) above the settled surface (soil.fill_height_m), z such that the
//   front face (local z = +T/2) is at motion.start_z_m (for a cone: its axis).
// - Insertion: straight down from the start pose to the tip at motion.depth_m below the surface in
//   `insertion_steps` whole FEM steps (study fem.dt_s), the fewest at which the speed does not exceed
//   motion.insertion_velocity_m_s (a cone: motion.velocity_m_s). The speed is the travel divided by
//   insertion_steps * dt.
// - Drag (not for a cone): from the end of the insertion at depth along +z at motion.velocity_m_s for
//   `drag_steps` = round(stroke / velocity / dt) whole FEM steps (at least 1).
// - Times are plan times: 0 at the start of the insertion. A run puts plan time 0 at the DEM clock's
//   value when its first FEM step begins.
#pragma once

#include "demfem/study/study.hpp"

#include <array>
#include <cstdint>

namespace demfem::study {

using Point3 = std::array<double, 3>;

// A straight motion at constant velocity: position(t) = origin + velocity (t - t0).
struct LinearMotion {
  Point3 origin_m{0, 0, 0};       // position at plan time t0_s
  Point3 velocity_m_s{0, 0, 0};
  double t0_s = 0;
  Point3 at(double t_s) const;
};

struct ToolMotionPlan {
  Point3 start_m{0, 0, 0};         // tip centre at rest before the insertion (see contract)
  double dt_s = 0;                 // FEM step
  std::int64_t insertion_steps = 0;
  std::int64_t drag_steps = 0;     // 0 for a cone
  LinearMotion insertion;          // from the start pose, t0 = 0
  LinearMotion drag;               // from the end of the insertion, t0 = insertion_steps * dt
  double depth_y_m = 0;            // tip height at depth: fill_height - depth

  std::int64_t totalSteps() const { return insertion_steps + drag_steps; }
  // The phase that moves the tool during FEM step `step` (0-based: plan times [step dt, (step+1) dt]).
  const LinearMotion& phaseOfStep(std::int64_t step) const { return step < insertion_steps ? insertion : drag; }
  // Tip centre at plan time t (t < 0: the start pose; after the drag: where it ends).
  Point3 positionAt(double t_s) const;
};

// One clock for both sides: the largest DEM step not above `dem_dt_s` that divides `fem_dt_s` into
// whole steps, so that simulate(dt_FEM) ends exactly on the FEM step (both backends use it).
// `fem_dt_s` <= 0 (no FEM step): `dem_dt_s` unchanged.
double demStepDividing(double dem_dt_s, double fem_dt_s);

// The plan of `tool` (one of study.tools) in `study` (validated by loadStudy). Throws
// std::invalid_argument for a kind without soil or a non-positive fem.dt_s, velocity or stroke.
ToolMotionPlan planToolMotion(const Study& study, const Tool& tool);

}  // namespace demfem::study
