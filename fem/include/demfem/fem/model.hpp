// demfem FEM model of a tool: consistent M and K, constraints, and the keypoint-reduced model of
// paper Section 2.6, Eq (11)-(15) (DESIGN.md section 4).
//
// Contract
// - Units: SI (m, kg, N, Pa). Frame: tool local frame (x width, y length with tip y = 0 and top
//   y = L, z thickness = travel direction).
// - DOF numbering: full model DOF 3 * node + c; reduced model DOF 3 * keypoint + c, c = 0, 1, 2 for
//   x, y, z. A reduced-model vector is therefore laid out exactly like an adapter::NodeArray (n x 3,
//   row-major) in keypoint id order.
// - Keypoints (Section 2.6): the nodes where the DEM side exchanges forces and displacements. Every
//   constrained DOF must be a keypoint DOF (the paper's rule: Eq (13) assumes f_b = 0 and no
//   constraint on the condensed nodes); reduce() rejects a model that breaks it with a
//   std::invalid_argument naming the offending nodes and DOFs. Loads enter only as keypoint forces.
// - The clamp (Section 2.9: all DOFs of the top 40 mm) is represented by fixing every DOF of the
//   KEYPOINTS in y >= L - clamp_length; the mid-side nodes in that region are not keypoints and stay
//   free, condensed by Eq (13) like every other non-keypoint node. Their motion is driven only by
//   the neighbouring free region and is tiny; CalculiX decks written for comparison fix exactly the
//   same nodes. The clamp's lower edge and the load-cell line must each lie on a keypoint row,
//   otherwise the model is rejected (message names the nearest keypoint rows).
// - A compliant clamp (tool.constraints.clamp_rotational_stiffness_Nm_per_rad = k_theta): the
//   keypoints of the clamp's lower edge row are pinned (x and z fixed) and each of them with
//   z != z_mid (the mid-plane) gets a ground spring along y of k_theta / sum_j (z_j - z_mid)^2, so
//   that a rotation theta of the edge section about x is resisted by the moment k_theta theta; the
//   keypoints above the edge (inside the clamp) are left free (they carry no load). As k_theta grows
//   this tends to the rigid clamp. The springs are part of the stiffness: FullModel::K and
//   ReducedModel::K include them, and Constraints::springs lists them (so that a caller scaling the
//   material stiffness, e.g. for a new E, can keep the springs unscaled).
// - The load cell (Section 2.9) fixes z of the keypoints on the line y = L - load_cell_from_top on
//   the back face (z = -T/2, the face opposite to the soil-engaging front face z = +T/2).
// - Reduction: T = [I; -K_bb^-1 K_ba], K_r = T^T K T = K_aa - K_ab K_bb^-1 K_ba (Eq 15), M_r = T^T M T
//   (the same transformation applied to M, as Section 2.6 prescribes "for the mass matrix").
//   K_bb is factorized once with CHOLMOD. The reduced matrices keep the constrained keypoint DOFs
//   (needed for the reactions of Eq 10); the constraints are applied by the solvers.
#pragma once

#include "demfem/fem/mesh.hpp"
#include "demfem/study/study.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace demfem::fem {

using SparseMatrix = Eigen::SparseMatrix<double>;  // column-major, symmetric matrices stored full

struct Material {
  double youngs_Pa = 0;
  double poisson = 0;
  double density_kg_m3 = 0;
};

// Gauss rule per direction for Hex20 stiffness: 2 = reduced (as CalculiX C3D20R), 3 = full (C3D20).
// Mass is always integrated with the full rule (consistent mass). Tet10 uses a 64-point collapsed
// Gauss rule (exact to degree 5) for both.
enum class HexIntegration { Reduced, Full };

// Consistent stiffness and mass matrices of `mesh` (3 DOF per node). Throws std::invalid_argument
// for an element with a non-positive Jacobian (names the element) or invalid material.
struct Assembled {
  SparseMatrix K;  // N/m
  SparseMatrix M;  // kg
};
Assembled assemble(const Mesh& mesh, const Material& material, HexIntegration integration);

// Where the tool is held (Section 2.9), as DOFs of the model.
struct Constraints {
  std::vector<int> fixed_dofs;      // every constrained DOF (clamp and load cell), sorted, unique
  std::vector<int> load_cell_dofs;  // the load cell's DOFs (subset of fixed_dofs), sorted
  // Ground springs (DOF, N/m) already contained in the model's K: the compliant clamp (contract).
  std::vector<std::pair<int, double>> springs;
};

// The full model: M, K over all nodes, the keypoints and the constraints.
struct FullModel {
  Mesh mesh;                                  // empty for MatrixMarket models
  SparseMatrix K, M;                          // 3 * node_count square
  std::vector<int> keypoint_nodes;            // node of keypoint id k
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> keypoints;  // undeformed, m
  Constraints constraints;                    // full-model DOFs
  double length_m = 0;                        // extent along y (top at y = length_m)
  int dofCount() const { return static_cast<int>(K.rows()); }
};

// The model reduced to the keypoints (Eq 15 for K, same T for M).
struct ReducedModel {
  Eigen::MatrixXd K, M;                       // 3n x 3n, symmetric, constrained DOFs included
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> keypoints;  // undeformed, m
  Constraints constraints;                    // reduced-model DOFs (3 * keypoint + c)
  double length_m = 0;
  int keypointCount() const { return static_cast<int>(keypoints.rows()); }
  int dofCount() const { return static_cast<int>(K.rows()); }
  std::vector<int> freeDofs() const;          // complement of constraints.fixed_dofs, sorted
};

// Plate tool of `tool` (GeometryKind::Plate): makePlateMesh on the keypoint grid, Section 2.9
// constraints from tool.constraints, material from tool.fem. Throws std::invalid_argument for a
// non-plate tool, an off-grid constraint line or invalid material.
FullModel buildPlateModel(const study::Tool& tool, HexIntegration integration = HexIntegration::Reduced);

// Any tool of the study: Plate (above), Gmsh (mesh_file in metres; keypoints = corner nodes of the
// mesh surface) or MatrixMarket (readMatrixMarketModel). Constraints from tool.constraints.
FullModel buildFullModel(const study::Tool& tool, HexIntegration integration = HexIntegration::Reduced);

// The tool of `study` named `name`, or its first deformable tool if `name` is empty. Throws
// std::invalid_argument naming the available tools if there is no such (deformable) tool.
const study::Tool& deformableTool(const study::Study& study, const std::string& name);

// Externally assembled M and K (MatrixMarket coordinate real, general or symmetric; e.g. exported by
// Ansys) plus a keypoint list file, one keypoint per line (`#` starts a comment):
//   <node index, 0-based, into the 3-DOF-per-node matrices> <x_m> <y_m> <z_m>
// and optional explicit constraint lines:
//   fix <node index> <x|y|z|xyz>        (clamp-type constraint)
//   load_cell <node index> <x|y|z>      (load-cell constraint)
// Without any fix/load_cell line, the Section 2.9 constraints of `constraints` are applied to the
// keypoints geometrically (top of the tool = largest keypoint y). Throws std::runtime_error naming
// file and line for malformed content.
FullModel readMatrixMarketModel(const std::filesystem::path& mass_file,
                                const std::filesystem::path& stiffness_file,
                                const std::filesystem::path& keypoint_file,
                                const study::ToolConstraints& constraints);

// Section 2.9 constraints applied to the keypoints of `model` geometrically (see contract): fills
// model.constraints and adds the clamp springs, if any, to model.K (pre: model.K holds no springs
// yet). Throws std::invalid_argument if the clamp edge or load-cell line is not on a keypoint row or
// the clamp edge row has no keypoint off the mid-plane.
void applyToolConstraints(FullModel& model, const study::ToolConstraints& constraints);

// Eq (11)-(15): reduces `model` to its keypoints. Throws std::invalid_argument if a constrained DOF
// is not a keypoint DOF (message lists node, coordinates and DOF), std::runtime_error if K_bb is not
// positive definite (a mechanism among the condensed nodes).
ReducedModel reduce(const FullModel& model);

// Adds a lumped mass (kg) to the diagonal of M at each listed reduced DOF (Section 2.10.1: the
// calibration weight on the pan rows).
void addLumpedMass(ReducedModel& model, const std::vector<int>& dofs, double mass_per_dof_kg);

// Static solution K u = f with the constraints (Eq 2). `f` are keypoint forces (3n, N); returns the
// keypoint displacements (m, zero at fixed DOFs) and the reactions (N, force of the supports on the
// tool, zero at free DOFs): K u = f + reactions.
struct StaticSolution {
  Eigen::VectorXd displacement;
  Eigen::VectorXd reaction;
};
StaticSolution solveStatic(const ReducedModel& model, const Eigen::VectorXd& f);
// The same on the full model (forces on all nodes, 3 * node_count).
StaticSolution solveStatic(const FullModel& model, const Eigen::VectorXd& f);

// The first `count` natural modes of the constrained model (shift-invert Lanczos, Spectra):
// frequencies in Hz ascending, shapes as columns (model DOFs, zero at fixed DOFs, M-normalized).
struct Modes {
  std::vector<double> frequencies_Hz;
  Eigen::MatrixXd shapes;
};
Modes naturalModes(const FullModel& model, int count);
Modes naturalModes(const ReducedModel& model, int count);

}  // namespace demfem::fem
