// The coupled DEM-FEM cycle of paper Fig. 3 (docs/architecture.md sections 1-4), driven from the FEM side
// through the abstract coupling API, exactly as the paper's client drives EDEM:
//   nodeForces -> FEM step (Eq 9, reactions Eq 10) -> setNodePositions -> simulate(dt_FEM), repeated.
//
// Contract
// - Units SI inside; the outputs carry units in their column/key names. Frames: keypoint data in
//   the tool's local frame (coupling_api.hpp); VTK files in the bin frame.
// - Setup: the DEM's geometry named like the study's (first) tool must have the FEM model's keypoints
//   (matchKeypoints(), within keypoint_tolerance_m) — otherwise std::invalid_argument naming the
//   offending node. The DEM may list its nodes in any order; the driver permutes.
// - Motion (Section 2.9, Fig. 4): the tool's motion plan (study/tool_motion.hpp), computed once from
//   the study. The DEM holds the tool at the plan's start pose (coupling_api.hpp, "After
//   construction"); plan time 0 is the DEM clock when the first FEM step begins. The driver sets
//   the insertion's RigidMotion before step 0 and the drag's before step insertion_steps; the run
//   has insertion_steps + drag_steps FEM steps.
// - Deformable tool (coupled study): the integrator of study fem.integration (makeIntegrator,
//   modal.hpp: ModalIntegrator by default, ThreeLevelIntegrator for "full") started at rest in static equilibrium under
//   the DEM's instantaneous forces at the start; each step uses the forces of the DEM's last interval
//   (study coupling.force_averaging) as the applied force of the new time level. Sensors:
//   fem::Sensors (load cell reaction, deformation at the sensor line, tip tilt).
// - Rigid tool (DEM-only study; the paper's S235 "DEM simulation"): no FEM step, positions never set;
//   the load-cell force is the tool's static split of the node forces, loadCellInfluence() of the
//   same FEM model (sensors.hpp), so a rigid and a deformable run of one tool read the same load
//   cell for the same static forces; deformation and tilt are 0.
// - Outputs in output_dir (docs/coupling-guide.md):
//   sensors.csv  `t_s,displacement_mm,force_N,deformation_mm,tilt_deg`, one row per FEM step of the
//                drag phase (t_s from the start of the drag; %.17g), sidecar sensors.json
//                {"tool","depth_mm","complete",...; "soil": the DEM's BackendInfo::soil_json if any};
//   keypoints.csv `id,x_m,y_m,z_m` undeformed keypoints (FEM order);
//   keypoint_displacements.f64  little-endian float64 records [t_s, u (3n, m, FEM keypoint order)],
//                one per drag-phase step;
//   vtk/fem-TOOL_NNNNNN.vtu (every vtk_every FEM steps; NNNNNN the FEM step that begins at that
//                instant; vtkio: binary, compressed, node displacement_m and the node force_N of
//                that step) and the collection vtk/fem-TOOL.pvd, timed on the DEM clock: the tool as
//                the DEM simulates it from that instant (the positions just sent), so a DEM
//                backend's files of the same step (builtin: vtk/dem-TOOL_NNNNNN.vtp) coincide.
//   The run holds output_dir's adapter::DirectoryLock (run.lock) from start to end: a second run
//   on the same directory, e.g. a second `demfem campaign` on one campaign directory, fails at
//   once with OutputError naming the directory and the holder, and writes nothing there.
//   Every write, sync, close and rename is checked (adapter/output_files.hpp). Streams are
//   written as NAME.partial and renamed when the run ends. A run that does not do the whole plan —
//   a failure, an interruption, or max_steps below the plan — is marked incomplete: the CSV gets a
//   trailer `# incomplete: REASON` and the sidecar "complete": false, "incomplete_reason": REASON
//   (max_steps: "stopped after N of M FEM steps"). A failure or interruption is then rethrown
//   (CoupledRunInterrupted for a stop request); when the marking itself fails (a full disk), the
//   rethrown message says which files could not be marked (a CSV left as sensors.csv.partial, a
//   sidecar still saying "running").
// - Checkpoint/restart: every checkpoint_every steps the DEM writes the checkpoint NAMED
//   dem_STEP.ckpt (through the API; the DEM server resolves it in its own checkpoint directory,
//   which `demfem run` sets to output_dir/checkpoint) and the driver then writes checkpoint/fem_state.bin (integrator state, step, plan start on the DEM
//   clock, output sizes), which commits the pair. resume = true restores both (nothing is re-sent:
//   the DEM's checkpoint holds the tool's motion, positions and their velocity), truncates the
//   outputs to the checkpoint and continues; on a backend whose checkpoint restores bit-identically
//   (builtin, test backends) the result equals an uninterrupted run bit for bit.
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
  std::int64_t step = 0, total_steps = 0;  // FEM steps done / to do in this run (insertion + drag)
  double time_s = 0, end_time_s = 0;       // simulated, from the start of the insertion
  double steps_per_s = 0, eta_s = 0;       // wall clock
};

struct CoupledRunOptions {
  std::filesystem::path output_dir = "out";
  std::optional<std::int64_t> max_steps;   // stop after this many FEM steps (outputs marked incomplete if short of the plan)
  std::int64_t checkpoint_every = 0;       // FEM steps between checkpoints; 0 = none
  bool resume = false;
  double keypoint_tolerance_m = 1e-6;
  std::function<void(const CoupledProgress&)> on_progress;  // after every step
  std::function<void(double)> on_reduction_progress;        // keypoint reduction, fraction done (reduce())
  // Keypoint reductions and modal bases read from and written to this directory
  // (reduction_cache.hpp); none: computed on every run. The run's numbers are the same either way.
  std::optional<std::filesystem::path> reduction_cache_dir;
  std::function<bool()> stop_requested;                     // checked before every step
};

struct CoupledRunSummary {
  bool rigid_tool = false;
  bool complete = false;               // the whole plan was run (see incomplete_reason otherwise)
  std::string incomplete_reason;       // e.g. "stopped after 120 of 1479 FEM steps"
  std::int64_t steps = 0;              // FEM steps in total (insertion + drag)
  std::int64_t planned_steps = 0;      // FEM steps of the study's motion plan
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
  // keypoints, adapter::CouplingError for DEM failures, adapter::OutputError for a failed write,
  // CoupledRunInterrupted when stop_requested() returned true; outputs are then marked incomplete
  // (see above).
  CoupledRunSummary run(adapter::CouplingApi& dem);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demfem::fem
