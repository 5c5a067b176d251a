// demfem tool sensors (paper Section 2.9, Fig. 5; DESIGN.md section 4) and keypoint matching with a
// DEM backend.
//
// Contract
// - Inputs are reduced-model vectors (3 * keypoint + c): keypoint displacements u (m) and the
//   reactions of ThreeLevelIntegrator::reactions() or solveStatic() (N, force of the supports on
//   the tool).
// - Sign convention: the soil pushes the tool against its travel, i.e. along -z of the tool frame.
//   Every sensor reads positive for such a load:
//   * load_cell_N: the force the soil exerts on the tool as measured by the load cell, positive
//     against travel: the sum of the z reactions at the load-cell DOFs (the support pushes the tool
//     forward, +z, when the soil pushes it back).
//   * deformation_mm: the deflection against travel, -u_z, at the sensor line
//     y = L - sensor_from_top, averaged over the keypoints of a row and interpolated linearly
//     between the two nearest keypoint rows (the 93 mm line is between rows of a 5 mm grid).
//   * Channel gains (tool.sensors): load_cell_N and deformation_mm are the true values times
//     force_gain and deformation_gain (1 = ideal sensors); tip_tilt_deg is not a measured channel
//     and has no gain.
//   * tip_tilt_deg: the bending slope at the tip, atan of the difference of the row-mean -u_z of the
//     lowest and second-lowest keypoint rows over their distance; positive when the tip is bent
//     backwards (against travel).
#pragma once

#include "demfem/fem/model.hpp"
#include "demfem/study/study.hpp"

#include <Eigen/Core>

#include <vector>

namespace demfem::fem {

struct SensorReadings {
  double load_cell_N = 0;
  double deformation_mm = 0;
  double tip_tilt_deg = 0;
};

// Precomputed rows and weights of the sensors of one model of `tool` (sensor line from
// tool.constraints, gains from tool.sensors). Throws std::invalid_argument if the sensor line lies
// outside the keypoints' y range or the model has no load-cell DOF.
class Sensors {
 public:
  Sensors(const ReducedModel& model, const study::Tool& tool);
  SensorReadings read(const Eigen::VectorXd& displacement, const Eigen::VectorXd& reactions) const;

 private:
  std::vector<int> load_cell_z_dofs_;
  std::vector<std::pair<int, double>> sensor_z_weights_;  // (z DOF, weight), weights sum to 1
  std::vector<std::pair<int, double>> tip_slope_weights_; // (z DOF, weight): slope of -u_z, 1/m
  study::ToolSensors gains_;
};

// The load cell's static influence coefficients (paper Section 2.9): c with load_cell_N = c . f
// (Sensors::read of solveStatic(model, f)) for any keypoint forces f (3n, N, model DOF order). By
// K u = f + r: r_c = K_cf K_ff^-1 f_f - f_c at the fixed DOFs, so one static solve gives them all:
// c_f = K_ff^-1 K_fc s (s the indicator of the load-cell z DOFs) and c_c = -s. Used for a rigid
// tool, whose load cell reads the same split of the soil forces as the deformable one at rest.
Eigen::VectorXd loadCellInfluence(const ReducedModel& model);

// Matches keypoint positions received from a DEM backend (n x 3, row-major, tool local frame, m) to
// the model's keypoints: result[i] is the model keypoint id of received node i. Positions match if
// they are within `tolerance_m`. Throws std::invalid_argument if the counts differ, a received node
// has no model keypoint within tolerance (names it, its position and the nearest keypoint) or two
// received nodes match the same keypoint.
std::vector<int> matchKeypoints(const ReducedModel& model, const std::vector<double>& received_xyz,
                                double tolerance_m);

}  // namespace demfem::fem
