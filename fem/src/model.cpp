#include "demfem/fem/model.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <Spectra/MatOp/DenseSymMatProd.h>
#include <Spectra/MatOp/SparseSymMatProd.h>
#include <Spectra/MatOp/SymShiftInvert.h>
#include <Spectra/SymGEigsShiftSolver.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>

namespace demfem::fem {
namespace {

// Geometric tolerance for "on a keypoint row" (m): far below any grid spacing, far above round-off.
constexpr double kRowTolerance_m = 1e-9;

const char* dofName(int c) { return c == 0 ? "x" : c == 1 ? "y" : "z"; }

std::string formatPoint(const Eigen::Vector3d& p) {
  std::ostringstream s;
  s << "(" << p.x() << ", " << p.y() << ", " << p.z() << ") m";
  return s.str();
}

Eigen::Vector3d nodePosition(const FullModel& model, int node) {
  if (!model.mesh.nodes.empty()) return model.mesh.nodes[static_cast<std::size_t>(node)];
  for (std::size_t k = 0; k < model.keypoint_nodes.size(); ++k)
    if (model.keypoint_nodes[k] == node) return model.keypoints.row(static_cast<Eigen::Index>(k)).transpose();
  return Eigen::Vector3d::Constant(std::nan(""));
}

// Sorted distinct keypoint y values (rows of the grid).
std::vector<double> keypointRows(const FullModel& model) {
  std::vector<double> rows;
  for (Eigen::Index k = 0; k < model.keypoints.rows(); ++k) rows.push_back(model.keypoints(k, 1));
  std::sort(rows.begin(), rows.end());
  std::vector<double> distinct;
  for (double y : rows)
    if (distinct.empty() || y - distinct.back() > kRowTolerance_m) distinct.push_back(y);
  return distinct;
}

void requireKeypointRow(const FullModel& model, double y, const std::string& what) {
  const auto rows = keypointRows(model);
  const auto it = std::lower_bound(rows.begin(), rows.end(), y - kRowTolerance_m);
  if (it != rows.end() && std::abs(*it - y) <= kRowTolerance_m) return;
  std::ostringstream s;
  s << what << " at y = " << y << " m is not on a keypoint row";
  if (it != rows.begin()) s << "; nearest rows below: y = " << *std::prev(it) << " m";
  if (it != rows.end()) s << "; above: y = " << *it << " m";
  s << ". Constraints must act on keypoints only (paper Section 2.6, Eq 13): move the constraint or "
       "change the keypoint spacing";
  throw std::invalid_argument(s.str());
}

std::vector<int> complement(int n, const std::vector<int>& sorted_subset) {
  std::vector<int> out;
  out.reserve(static_cast<std::size_t>(n) - sorted_subset.size());
  auto it = sorted_subset.begin();
  for (int i = 0; i < n; ++i) {
    if (it != sorted_subset.end() && *it == i) {
      ++it;
      continue;
    }
    out.push_back(i);
  }
  return out;
}

// Rows/columns `rows` x `cols` of a sparse matrix, as a sparse matrix.
SparseMatrix extract(const SparseMatrix& A, const std::vector<int>& rows, const std::vector<int>& cols) {
  std::vector<int> row_pos(static_cast<std::size_t>(A.rows()), -1), col_pos(static_cast<std::size_t>(A.cols()), -1);
  for (std::size_t i = 0; i < rows.size(); ++i) row_pos[static_cast<std::size_t>(rows[i])] = static_cast<int>(i);
  for (std::size_t j = 0; j < cols.size(); ++j) col_pos[static_cast<std::size_t>(cols[j])] = static_cast<int>(j);
  std::vector<Eigen::Triplet<double>> entries;
  for (int c = 0; c < A.outerSize(); ++c) {
    if (col_pos[static_cast<std::size_t>(c)] < 0) continue;
    for (SparseMatrix::InnerIterator it(A, c); it; ++it) {
      const int r = row_pos[static_cast<std::size_t>(it.row())];
      if (r >= 0) entries.emplace_back(r, col_pos[static_cast<std::size_t>(c)], it.value());
    }
  }
  SparseMatrix out(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(cols.size()));
  out.setFromTriplets(entries.begin(), entries.end());
  return out;
}

Eigen::MatrixXd extractDense(const Eigen::MatrixXd& A, const std::vector<int>& rows, const std::vector<int>& cols) {
  return A(rows, cols);
}

Material materialOf(const study::Tool& tool) {
  return {tool.fem.youngs_Pa, tool.fem.poisson, tool.fem.density_kg_m3};
}

// Keypoints of a Gmsh mesh: the corner nodes of the boundary faces.
std::vector<int> surfaceCornerNodes(const Mesh& mesh) {
  static constexpr int kHexFaces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  static constexpr int kTetFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  std::map<std::vector<int>, int> face_count;
  auto add = [&](std::vector<int> face) {
    std::sort(face.begin(), face.end());
    ++face_count[face];
  };
  for (const Element& e : mesh.elements) {
    if (e.type == ElementType::Hex20)
      for (const auto& f : kHexFaces) add({e.nodes[f[0]], e.nodes[f[1]], e.nodes[f[2]], e.nodes[f[3]]});
    else
      for (const auto& f : kTetFaces) add({e.nodes[f[0]], e.nodes[f[1]], e.nodes[f[2]]});
  }
  std::set<int> nodes;
  for (const auto& [face, count] : face_count)
    if (count == 1) nodes.insert(face.begin(), face.end());
  return {nodes.begin(), nodes.end()};
}

FullModel modelFromMesh(Mesh mesh, std::vector<int> keypoint_nodes, const study::Tool& tool, HexIntegration integration) {
  FullModel model;
  Assembled a = assemble(mesh, materialOf(tool), integration);
  model.K = std::move(a.K);
  model.M = std::move(a.M);
  model.keypoints.resize(static_cast<Eigen::Index>(keypoint_nodes.size()), 3);
  for (std::size_t k = 0; k < keypoint_nodes.size(); ++k)
    model.keypoints.row(static_cast<Eigen::Index>(k)) = mesh.nodes[static_cast<std::size_t>(keypoint_nodes[k])].transpose();
  model.keypoint_nodes = std::move(keypoint_nodes);
  model.mesh = std::move(mesh);
  applyToolConstraints(model, tool.constraints);
  return model;
}

// MatrixMarket coordinate reader with file:line messages (Eigen's loadMarket reports no position).
SparseMatrix readMarket(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot open MatrixMarket file");
  std::string line;
  int line_no = 0;
  auto fail = [&](const std::string& message) {
    throw std::runtime_error(file.string() + ":" + std::to_string(line_no) + ": " + message);
  };
  if (!std::getline(in, line)) fail("empty file");
  ++line_no;
  std::istringstream banner(line);
  std::string tag, object, format, field, symmetry;
  banner >> tag >> object >> format >> field >> symmetry;
  std::transform(symmetry.begin(), symmetry.end(), symmetry.begin(), ::tolower);
  if (tag != "%%MatrixMarket" || object != "matrix" || format != "coordinate" || (field != "real" && field != "double"))
    fail("expected '%%MatrixMarket matrix coordinate real general|symmetric', got '" + line + "'");
  if (symmetry != "general" && symmetry != "symmetric") fail("symmetry '" + symmetry + "' is not supported");
  long rows = -1, cols = -1, entries = -1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '%') continue;
    std::istringstream s(line);
    if (!(s >> rows >> cols >> entries) || rows <= 0 || rows != cols) fail("expected a square size line 'rows cols entries'");
    break;
  }
  if (entries < 0) fail("no size line");
  std::vector<Eigen::Triplet<double>> triplets;
  for (long e = 0; e < entries; ++e) {
    do {
      if (!std::getline(in, line)) fail("file ends after " + std::to_string(e) + " of " + std::to_string(entries) + " entries");
      ++line_no;
    } while (line.empty() || line[0] == '%');
    std::istringstream s(line);
    long i = 0, j = 0;
    double v = 0;
    if (!(s >> i >> j >> v)) fail("expected 'row column value', got '" + line + "'");
    if (i < 1 || j < 1 || i > rows || j > cols) fail("index out of range 1.." + std::to_string(rows));
    if (!std::isfinite(v)) fail("value is not finite");
    triplets.emplace_back(i - 1, j - 1, v);
    if (symmetry == "symmetric" && i != j) triplets.emplace_back(j - 1, i - 1, v);
  }
  SparseMatrix A(rows, cols);
  A.setFromTriplets(triplets.begin(), triplets.end());
  return A;
}

int parseDofMask(const std::string& text) {
  int mask = 0;
  for (char c : text) {
    if (c == 'x') mask |= 1;
    else if (c == 'y') mask |= 2;
    else if (c == 'z') mask |= 4;
    else return -1;
  }
  return mask;
}

// Solves A x = b with a factorization of A plus two steps of iterative refinement whose residual is
// accumulated in extended precision: the thin plate's K is ill conditioned, and refinement in the
// working precision alone would leave an error of cond(K) * eps.
template <class Solver, class Matrix>
Eigen::VectorXd solveRefined(const Solver& solver, const Matrix& A, const Eigen::VectorXd& b) {
  Eigen::VectorXd x = solver.solve(b);
  const auto A_extended = A.template cast<long double>().eval();
  for (int pass = 0; pass < 2; ++pass) {
    const Eigen::VectorXd residual =
        (b.cast<long double>() - A_extended * x.cast<long double>()).template cast<double>();
    x += solver.solve(residual);
  }
  if (!x.allFinite()) throw std::runtime_error("static solve failed (non-finite displacement)");
  return x;
}

// The compliant clamp's springs: `springs` holds (y DOF, squared lever arm (z - z_mid)^2); each
// gets the stiffness k_theta / sum of the squared arms (moment k_theta theta for a rotation theta),
// which replaces the arm in `springs`, and is added to the diagonal of K.
void addClampSprings(SparseMatrix& K, std::vector<std::pair<int, double>>& springs, double k_theta_Nm_per_rad) {
  double arm_sum = 0;
  for (const auto& [dof, arm2] : springs) arm_sum += arm2;
  if (springs.empty() || !(arm_sum > 0))
    throw std::invalid_argument("compliant clamp: the clamp edge row has no keypoint off the mid-plane to carry the rotational spring");
  for (auto& [dof, stiffness] : springs) {
    stiffness = k_theta_Nm_per_rad / arm_sum;
    K.coeffRef(dof, dof) += stiffness;
  }
}

}  // namespace

std::vector<int> ReducedModel::freeDofs() const { return complement(dofCount(), constraints.fixed_dofs); }

void applyToolConstraints(FullModel& model, const study::ToolConstraints& constraints) {
  if (model.keypoints.rows() == 0) throw std::invalid_argument("tool constraints: the model has no keypoints");
  if (!(constraints.clamp_length_m > 0)) throw std::invalid_argument("tool constraints: clamp_length must be > 0 m");
  const double top = model.keypoints.col(1).maxCoeff();
  const double back = model.keypoints.col(2).minCoeff();
  model.length_m = top - model.keypoints.col(1).minCoeff();
  const double clamp_edge = top - constraints.clamp_length_m;
  const double load_cell_y = top - constraints.load_cell_from_top_m;
  requireKeypointRow(model, clamp_edge, "the clamp's lower edge (clamp_length " + std::to_string(constraints.clamp_length_m) + " m)");
  requireKeypointRow(model, load_cell_y, "the load-cell line (load_cell_from_top " + std::to_string(constraints.load_cell_from_top_m) + " m)");
  Constraints c;
  const auto& rotational = constraints.clamp_rotational_stiffness_Nm_per_rad;
  const double z_mid = 0.5 * (back + model.keypoints.col(2).maxCoeff());
  for (Eigen::Index k = 0; k < model.keypoints.rows(); ++k) {
    const int node = model.keypoint_nodes[static_cast<std::size_t>(k)];
    const double y = model.keypoints(k, 1), z = model.keypoints(k, 2);
    if (!rotational && y >= clamp_edge - kRowTolerance_m)
      for (int d = 0; d < 3; ++d) c.fixed_dofs.push_back(3 * node + d);
    if (rotational && std::abs(y - clamp_edge) <= kRowTolerance_m) {
      c.fixed_dofs.push_back(3 * node);      // pinned edge: x and z fixed,
      c.fixed_dofs.push_back(3 * node + 2);  // y held by the spring below
      if (std::abs(z - z_mid) > kRowTolerance_m) c.springs.emplace_back(3 * node + 1, (z - z_mid) * (z - z_mid));
    }
    if (std::abs(y - load_cell_y) <= kRowTolerance_m && std::abs(z - back) <= kRowTolerance_m) {
      c.load_cell_dofs.push_back(3 * node + 2);
      c.fixed_dofs.push_back(3 * node + 2);
    }
  }
  std::sort(c.fixed_dofs.begin(), c.fixed_dofs.end());
  c.fixed_dofs.erase(std::unique(c.fixed_dofs.begin(), c.fixed_dofs.end()), c.fixed_dofs.end());
  std::sort(c.load_cell_dofs.begin(), c.load_cell_dofs.end());
  if (rotational) addClampSprings(model.K, c.springs, *rotational);
  model.constraints = std::move(c);
}

FullModel buildPlateModel(const study::Tool& tool, HexIntegration integration) {
  if (tool.geometry.kind != study::GeometryKind::Plate)
    throw std::invalid_argument("tool '" + tool.name + "': buildPlateModel needs a plate geometry");
  const auto& g = tool.geometry;
  PlateMesh plate = makePlateMesh(g.length_m, g.width_m, g.thickness_m, g.keypoint_spacing_m);
  return modelFromMesh(std::move(plate.mesh), std::move(plate.keypoint_nodes), tool, integration);
}

FullModel buildFullModel(const study::Tool& tool, HexIntegration integration) {
  switch (tool.geometry.kind) {
    case study::GeometryKind::Plate:
      return buildPlateModel(tool, integration);
    case study::GeometryKind::Gmsh: {
      Mesh mesh = readGmshMesh(tool.geometry.mesh_file, 1.0);
      std::vector<int> keypoints = surfaceCornerNodes(mesh);
      return modelFromMesh(std::move(mesh), std::move(keypoints), tool, integration);
    }
    case study::GeometryKind::MatrixMarket:
      return readMatrixMarketModel(tool.geometry.mass_file, tool.geometry.stiffness_file, tool.geometry.keypoint_file,
                                   tool.constraints);
    case study::GeometryKind::Cone:
      break;
  }
  throw std::invalid_argument("tool '" + tool.name + "': a cone penetrometer is rigid and has no FEM model");
}

const study::Tool& deformableTool(const study::Study& study, const std::string& name) {
  std::string available;
  for (const study::Tool& tool : study.tools) {
    if ((name.empty() || tool.name == name) && tool.fem.deformable) return tool;
    available += (available.empty() ? "" : ", ") + tool.name + (tool.fem.deformable ? "" : " (rigid)");
  }
  throw std::invalid_argument("study '" + study.name + "' has no deformable tool" + (name.empty() ? "" : " named '" + name + "'") +
                              " (tools: " + (available.empty() ? "none" : available) + ")");
}

FullModel readMatrixMarketModel(const std::filesystem::path& mass_file, const std::filesystem::path& stiffness_file,
                                const std::filesystem::path& keypoint_file, const study::ToolConstraints& constraints) {
  FullModel model;
  model.M = readMarket(mass_file);
  model.K = readMarket(stiffness_file);
  if (model.M.rows() != model.K.rows())
    throw std::runtime_error(mass_file.string() + " (" + std::to_string(model.M.rows()) + " rows) and " + stiffness_file.string() +
                             " (" + std::to_string(model.K.rows()) + " rows) differ in size");
  if (model.K.rows() % 3 != 0)
    throw std::runtime_error(stiffness_file.string() + ": size " + std::to_string(model.K.rows()) + " is not 3 DOF per node");
  const int nodes = static_cast<int>(model.K.rows() / 3);
  std::ifstream in(keypoint_file);
  if (!in) throw std::runtime_error(keypoint_file.string() + ": cannot open keypoint list");
  std::vector<Eigen::Vector3d> positions;
  Constraints explicit_constraints;
  std::string line;
  int line_no = 0;
  auto fail = [&](const std::string& message) {
    throw std::runtime_error(keypoint_file.string() + ":" + std::to_string(line_no) + ": " + message);
  };
  auto node_in_range = [&](long node) {
    if (node < 0 || node >= nodes) fail("node index " + std::to_string(node) + " outside 0.." + std::to_string(nodes - 1));
    return static_cast<int>(node);
  };
  while (std::getline(in, line)) {
    ++line_no;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream s(line);
    std::string first;
    if (!(s >> first)) continue;
    if (first == "fix" || first == "load_cell") {
      long node = 0;
      std::string dofs;
      if (!(s >> node >> dofs)) fail("expected '" + first + " <node> <x|y|z|xyz>'");
      const int mask = parseDofMask(dofs);
      if (mask <= 0) fail("DOF list '" + dofs + "' must be made of x, y, z");
      const int n = node_in_range(node);
      for (int d = 0; d < 3; ++d)
        if (mask & (1 << d)) {
          explicit_constraints.fixed_dofs.push_back(3 * n + d);
          if (first == "load_cell") explicit_constraints.load_cell_dofs.push_back(3 * n + d);
        }
      continue;
    }
    long node = 0;
    double x = 0, y = 0, z = 0;
    std::istringstream full(line);
    if (!(full >> node >> x >> y >> z)) fail("expected '<node> <x_m> <y_m> <z_m>', 'fix ...' or 'load_cell ...'");
    model.keypoint_nodes.push_back(node_in_range(node));
    positions.emplace_back(x, y, z);
  }
  if (positions.empty()) throw std::runtime_error(keypoint_file.string() + ": no keypoints listed");
  model.keypoints.resize(static_cast<Eigen::Index>(positions.size()), 3);
  for (std::size_t k = 0; k < positions.size(); ++k) model.keypoints.row(static_cast<Eigen::Index>(k)) = positions[k].transpose();
  if (explicit_constraints.fixed_dofs.empty()) {
    applyToolConstraints(model, constraints);
  } else {
    if (constraints.clamp_rotational_stiffness_Nm_per_rad)
      throw std::runtime_error(keypoint_file.string() + ": lists explicit fix/load_cell constraints, so the study's "
                               "clamp_rotational_stiffness_Nm_per_rad cannot be placed; remove one of them");
    for (auto* v : {&explicit_constraints.fixed_dofs, &explicit_constraints.load_cell_dofs}) {
      std::sort(v->begin(), v->end());
      v->erase(std::unique(v->begin(), v->end()), v->end());
    }
    model.constraints = std::move(explicit_constraints);
    model.length_m = model.keypoints.col(1).maxCoeff() - model.keypoints.col(1).minCoeff();
  }
  return model;
}

ReducedModel reduce(const FullModel& model) {
  const int n = model.dofCount();
  std::vector<int> keypoint_dof_of(static_cast<std::size_t>(n), -1);  // full DOF -> reduced DOF
  std::vector<int> a_dofs;                                           // reduced DOF -> full DOF
  for (std::size_t k = 0; k < model.keypoint_nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) {
      const int full = 3 * model.keypoint_nodes[k] + d;
      if (keypoint_dof_of[static_cast<std::size_t>(full)] >= 0)
        throw std::invalid_argument("keypoint list names node " + std::to_string(model.keypoint_nodes[k]) + " twice");
      keypoint_dof_of[static_cast<std::size_t>(full)] = static_cast<int>(a_dofs.size());
      a_dofs.push_back(full);
    }
  // The paper's rule (Section 2.6): constraints only on keypoints.
  std::ostringstream offending;
  int offending_count = 0;
  for (int dof : model.constraints.fixed_dofs) {
    if (keypoint_dof_of[static_cast<std::size_t>(dof)] >= 0) continue;
    if (offending_count++ < 20) offending << "\n  node " << dof / 3 << " " << formatPoint(nodePosition(model, dof / 3)) << " DOF " << dofName(dof % 3);
  }
  if (offending_count > 0)
    throw std::invalid_argument(std::to_string(offending_count) +
                                " constrained DOF(s) are not keypoint DOFs; keypoint substructuring (paper Section 2.6, "
                                "Eq 13) allows constraints on keypoints only:" + offending.str() +
                                (offending_count > 20 ? "\n  ..." : ""));
  std::vector<int> b_dofs;
  for (int dof = 0; dof < n; ++dof)
    if (keypoint_dof_of[static_cast<std::size_t>(dof)] < 0) b_dofs.push_back(dof);

  ReducedModel r;
  r.keypoints = model.keypoints;
  r.length_m = model.length_m;
  for (int dof : model.constraints.fixed_dofs) r.constraints.fixed_dofs.push_back(keypoint_dof_of[static_cast<std::size_t>(dof)]);
  for (int dof : model.constraints.load_cell_dofs) r.constraints.load_cell_dofs.push_back(keypoint_dof_of[static_cast<std::size_t>(dof)]);
  for (const auto& [dof, stiffness] : model.constraints.springs)  // on keypoints by construction
    r.constraints.springs.emplace_back(keypoint_dof_of[static_cast<std::size_t>(dof)], stiffness);
  std::sort(r.constraints.fixed_dofs.begin(), r.constraints.fixed_dofs.end());
  std::sort(r.constraints.load_cell_dofs.begin(), r.constraints.load_cell_dofs.end());

  const SparseMatrix K_aa = extract(model.K, a_dofs, a_dofs);
  const Eigen::MatrixXd M_aa = extract(model.M, a_dofs, a_dofs);
  if (b_dofs.empty()) {
    r.K = K_aa;
    r.M = M_aa;
    return r;
  }
  const SparseMatrix K_bb = extract(model.K, b_dofs, b_dofs);
  const SparseMatrix K_ba = extract(model.K, b_dofs, a_dofs);
  const SparseMatrix M_bb = extract(model.M, b_dofs, b_dofs);
  const SparseMatrix M_ba = extract(model.M, b_dofs, a_dofs);
  // CHOLMOD's simplicial factor: on these banded K_bb it beats the supernodal one, whose dense
  // kernels go through the system BLAS.
  Eigen::CholmodSimplicialLLT<SparseMatrix> K_bb_factor(K_bb);  // factorized once
  if (K_bb_factor.info() != Eigen::Success)
    throw std::runtime_error("keypoint reduction: K_bb (the " + std::to_string(b_dofs.size()) +
                             " non-keypoint DOFs) is not positive definite: the condensed nodes form a mechanism");
  // Eq (13): u_b = T_b u_a with T_b = -K_bb^-1 K_ba; T = [I; T_b].
  Eigen::MatrixXd T_b = -K_bb_factor.solve(Eigen::MatrixXd(K_ba));
  // Eq (15): K_r = K_aa - K_ab K_bb^-1 K_ba = K_aa + K_ba^T T_b. For a thin plate this subtracts
  // nearly equal numbers (membrane-size entries leaving a bending-size result), so T_b gets one step
  // of iterative refinement and K_r is accumulated with residuals in extended precision, in column
  // blocks to bound the memory.
  using ExtendedMatrix = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  const Eigen::SparseMatrix<long double> K_bb_ext = K_bb.cast<long double>(), K_ba_ext = K_ba.cast<long double>(),
                                         K_aa_ext = K_aa.cast<long double>();
  const Eigen::SparseMatrix<long double> K_ab_ext = K_ba_ext.transpose();
  r.K.resize(T_b.cols(), T_b.cols());
  constexpr Eigen::Index kBlock = 64;
  for (Eigen::Index c0 = 0; c0 < T_b.cols(); c0 += kBlock) {
    const Eigen::Index w = std::min(kBlock, T_b.cols() - c0);
    const ExtendedMatrix K_ba_block(K_ba_ext.middleCols(c0, w));
    const Eigen::MatrixXd residual = (-K_ba_block - K_bb_ext * T_b.middleCols(c0, w).cast<long double>()).cast<double>();
    T_b.middleCols(c0, w) += K_bb_factor.solve(residual);
    r.K.middleCols(c0, w) =
        (ExtendedMatrix(K_aa_ext.middleCols(c0, w)) + K_ab_ext * T_b.middleCols(c0, w).cast<long double>()).cast<double>();
  }
  // M_r = T^T M T = M_aa + M_ab T_b + T_b^T M_ba + T_b^T M_bb T_b. The last term, the only dense
  // product, as Z^T Z with Z = L^T P T_b (M_bb = P^T L L^T P): a symmetric rank-k update, half a GEMM.
  const Eigen::MatrixXd M_ab_T = M_ba.transpose() * T_b;
  Eigen::SimplicialLLT<SparseMatrix> M_bb_factor(M_bb);
  if (M_bb_factor.info() != Eigen::Success) throw std::runtime_error("keypoint reduction: M_bb is not positive definite");
  const Eigen::MatrixXd Z = M_bb_factor.matrixU() * (M_bb_factor.permutationP() * T_b);
  Eigen::MatrixXd TMT = Eigen::MatrixXd::Zero(T_b.cols(), T_b.cols());
  TMT.selfadjointView<Eigen::Lower>().rankUpdate(Z.transpose());
  r.M = M_aa + M_ab_T + M_ab_T.transpose();
  r.M += TMT.selfadjointView<Eigen::Lower>();
  // Symmetric up to round-off; make it exact so Cholesky and Lanczos see a symmetric matrix.
  r.K = 0.5 * (r.K + r.K.transpose()).eval();
  r.M = 0.5 * (r.M + r.M.transpose()).eval();
  return r;
}

void addLumpedMass(ReducedModel& model, const std::vector<int>& dofs, double mass_per_dof_kg) {
  if (!(mass_per_dof_kg >= 0)) throw std::invalid_argument("lumped mass must be >= 0 kg");
  for (int dof : dofs) {
    if (dof < 0 || dof >= model.dofCount()) throw std::invalid_argument("lumped mass DOF " + std::to_string(dof) + " out of range");
    model.M(dof, dof) += mass_per_dof_kg;
  }
}

StaticSolution solveStatic(const ReducedModel& model, const Eigen::VectorXd& f) {
  if (f.size() != model.dofCount()) throw std::invalid_argument("solveStatic: force vector has the wrong size");
  const std::vector<int> free = model.freeDofs();
  const Eigen::MatrixXd K_ff = extractDense(model.K, free, free);
  Eigen::LLT<Eigen::MatrixXd> K_ff_factor(K_ff);
  if (K_ff_factor.info() != Eigen::Success) throw std::runtime_error("solveStatic: K on the free DOFs is not positive definite (tool not held?)");
  StaticSolution s;
  s.displacement = Eigen::VectorXd::Zero(model.dofCount());
  s.displacement(free) = solveRefined(K_ff_factor, K_ff, Eigen::VectorXd(f(free)));
  s.reaction = model.K * s.displacement - f;  // Eq (2) with the support forces
  s.reaction(free).setZero();
  return s;
}

StaticSolution solveStatic(const FullModel& model, const Eigen::VectorXd& f) {
  if (f.size() != model.dofCount()) throw std::invalid_argument("solveStatic: force vector has the wrong size");
  const std::vector<int> free = complement(model.dofCount(), model.constraints.fixed_dofs);
  const SparseMatrix K_ff = extract(model.K, free, free);
  Eigen::CholmodSimplicialLLT<SparseMatrix> K_ff_factor(K_ff);
  if (K_ff_factor.info() != Eigen::Success) throw std::runtime_error("solveStatic: K on the free DOFs is not positive definite (tool not held?)");
  StaticSolution s;
  s.displacement = Eigen::VectorXd::Zero(model.dofCount());
  s.displacement(free) = solveRefined(K_ff_factor, K_ff, Eigen::VectorXd(f(free)));
  s.reaction = model.K * s.displacement - f;
  s.reaction(free).setZero();
  return s;
}

namespace {

// Shift-invert Lanczos (Spectra) on the free DOFs; shapes expanded to all DOFs, M-normalized.
template <class OpType, class BOpType, class Matrix>
Modes lowestModes(const Matrix& K_ff, const Matrix& M_ff, const std::vector<int>& free, int dofs, int count) {
  const auto n = static_cast<Eigen::Index>(free.size());
  if (count < 1 || count >= n) throw std::invalid_argument("natural modes: count must be in 1.." + std::to_string(n - 1));
  OpType op(K_ff, M_ff);
  BOpType bop(M_ff);
  const Eigen::Index ncv = std::min<Eigen::Index>(n, std::max<Eigen::Index>(2 * count + 1, 20));
  Spectra::SymGEigsShiftSolver<OpType, BOpType, Spectra::GEigsMode::ShiftInvert> eigs(op, bop, count, ncv, 0.0);
  eigs.init();
  eigs.compute(Spectra::SortRule::LargestMagn, 1000, 1e-12);
  if (eigs.info() != Spectra::CompInfo::Successful) throw std::runtime_error("natural modes: the eigen solver did not converge");
  const Eigen::VectorXd lambda = eigs.eigenvalues();
  const Eigen::MatrixXd vectors = eigs.eigenvectors();
  std::vector<int> order(static_cast<std::size_t>(lambda.size()));
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return lambda(a) < lambda(b); });
  Modes modes;
  modes.shapes = Eigen::MatrixXd::Zero(dofs, count);
  for (int m = 0; m < count; ++m) {
    const int i = order[static_cast<std::size_t>(m)];
    modes.frequencies_Hz.push_back(std::sqrt(std::max(0.0, lambda(i))) / (2 * std::numbers::pi));
    Eigen::VectorXd phi = vectors.col(i);
    phi /= std::sqrt(phi.dot(M_ff * phi));
    Eigen::VectorXd column = Eigen::VectorXd::Zero(dofs);
    column(free) = phi;
    modes.shapes.col(m) = column;
  }
  return modes;
}

}  // namespace

Modes naturalModes(const FullModel& model, int count) {
  const std::vector<int> free = complement(model.dofCount(), model.constraints.fixed_dofs);
  const SparseMatrix K_ff = extract(model.K, free, free), M_ff = extract(model.M, free, free);
  return lowestModes<Spectra::SymShiftInvert<double, Eigen::Sparse, Eigen::Sparse>, Spectra::SparseSymMatProd<double>>(
      K_ff, M_ff, free, model.dofCount(), count);
}

Modes naturalModes(const ReducedModel& model, int count) {
  const std::vector<int> free = model.freeDofs();
  const Eigen::MatrixXd K_ff = extractDense(model.K, free, free), M_ff = extractDense(model.M, free, free);
  return lowestModes<Spectra::SymShiftInvert<double, Eigen::Dense, Eigen::Dense>, Spectra::DenseSymMatProd<double>>(
      K_ff, M_ff, free, model.dofCount(), count);
}

}  // namespace demfem::fem
