// The coupled DEM-FEM cycle of paper Fig. 3 (DESIGN.md sections 1-4), driven from the FEM side
// through the abstract coupling API, exactly as the paper's client drives EDEM:
//   nodeForces -> FEM step (Eq 9, reactions Eq 10) -> setNodePositions -> simulate(dt_FEM), repeated.
//
// Contract
// - Units SI inside; the outputs carry units in their column/key names. Frames: keypoint data in
//   the tool's local frame (coupling_api.hpp); VTK files in the bin frame.
// - Setup: the DEM's geometry named like the study's (first) tool must have the FEM model's keypoints
//   (matchKeypoints(), within keypoint_tolerance_m) — otherwise std::invalid_argument naming the
//   offending node. The DEM may list its nodes in any order; the driver permutes.
// - Motion (Section 2.9, Fig. 4): the tool starts with its tip one maximum particle diameter above
//   the soil surface (fill_height), centred across the bin at start_z_m; it is inserted vertically to
//   `depth` in a whole number of FEM steps (at the study's insertion velocity or slightly slower),
//   then dragged in +z at the study velocity for stroke / velocity. The driver sets the geometry's
//   RigidMotion at the start of each phase; the DEM moves the tool.
// - Deformable tool (coupled study): ThreeLevelIntegrator started at rest in static equilibrium under
//   the DEM's instantaneous forces at the start; each step uses the forces of the DEM's last interval
//   (study coupling.force_averaging) as the applied force of the new time level. Sensors:
//   fem::Sensors (load cell reaction, deformation at the sensor line, tip tilt).
// - Rigid tool (DEM-only study or tool.fem.deformable = false; the paper's S235 "DEM simulation"):
//   no FEM step, positions never set; the load-cell force follows from the node forces by moment
//   equilibrium about the clamp's lower edge (Section 2.9, "the lever effect"):
//     F_lc = sum_i (-f_z,i) (y_c - y_i) / (y_c - y_lc)   over keypoints below the clamp edge y_c,
//   y_lc the load-cell line; deformation and tilt are 0.
// - Outputs in output_dir (docs/coupling-guide.md):
//   sensors.csv  `t_s,displacement_mm,force_N,deformation_mm,tilt_deg`, one row per FEM step of the
//                drag phase (t_s from the start of the drag; %.17g), sidecar sensors.json
//                {"tool","depth_mm","complete",...};
//   keypoints.csv `id,x_m,y_m,z_m` undeformed keypoints (FEM order);
//   keypoint_displacements.f64  little-endian float64 records [t_s, u (3n, m, FEM keypoint order)],
//                one per drag-phase step; vtk/tool_NNNNNN.vtk every vtk_every steps.
//   Files are written as NAME.partial and renamed when the run completes. On a failure or an
//   interruption they are renamed too, the CSV gets a trailer line `# incomplete: REASON` and the
//   sidecar "complete": false, "incomplete_reason": REASON; then the exception is rethrown
//   (CoupledRunInterrupted for a stop request).
// - Checkpoint/restart: every checkpoint_every steps the DEM writes the checkpoint NAMED
//   dem_STEP.ckpt (through the API; the DEM server resolves it in its own checkpoint directory,
//   which `demfem run` sets to output_dir/checkpoint) and the driver then writes checkpoint/fem_state.bin (integrator state, step, output sizes), which
//   commits the pair. resume = true restores both, truncates the outputs to
//   the checkpoint and continues; the result equals an uninterrupted run bit for bit.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/study/study.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

namespace demfem::fem {

struct CoupledProgress {
  std::int64_t step = 0, total_steps = 0;  // FEM steps done / planned (insertion + drag)
  double time_s = 0, end_time_s = 0;       // simulated
  double steps_per_s = 0, eta_s = 0;       // wall clock
};

struct CoupledRunOptions {
  std::filesystem::path output_dir = "out";
  std::optional<std::int64_t> max_steps;   // stop (complete) after this many FEM steps
  std::int64_t checkpoint_every = 0;       // FEM steps between checkpoints; 0 = none
  bool resume = false;
  double keypoint_tolerance_m = 1e-6;
  std::function<void(const CoupledProgress&)> on_progress;  // after every step
  std::function<bool()> stop_requested;                     // checked before every step
};

struct CoupledRunSummary {
  bool rigid_tool = false;
  std::int64_t steps = 0;              // FEM steps in total (insertion + drag)
  std::int64_t drag_steps = 0;         // rows of sensors.csv
  double simulated_time_s = 0;
  double wall_time_s = 0;              // this invocation only
  double mean_force_N = 0;             // over the drag phase
  double max_force_N = 0;
  double final_deformation_mm = 0;
  double final_tilt_deg = 0;
  std::string backend;
};

class CoupledRunInterrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Drives the first tool of a study (kind Coupled or DemOnly).
class CoupledDriver {
 public:
  // Builds the FEM model (Eq 11-15 reduction: the slow part) before any DEM is contacted, so a
  // server's idle timeout does not run during it. Throws std::invalid_argument for a study it cannot
  // run (other kinds, no tool, bad motion) or an invalid FEM model.
  CoupledDriver(const study::Study& study, CoupledRunOptions options);
  ~CoupledDriver();
  CoupledDriver(const CoupledDriver&) = delete;
  CoupledDriver& operator=(const CoupledDriver&) = delete;

  // Runs the cycle against `dem` (once per driver). Throws std::invalid_argument for mismatched
  // keypoints, adapter::CouplingError for DEM failures, CoupledRunInterrupted when
  // stop_requested() returned true; outputs are then marked incomplete (see above).
  CoupledRunSummary run(adapter::CouplingApi& dem);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demfem::fem
