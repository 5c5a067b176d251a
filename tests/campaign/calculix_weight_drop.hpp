// Test fixture: calibration-weight recordings from CalculiX (Debian calculix-ccx, `ccx`), a second
// generator INDEPENDENT of the project's FEM code (docs/diagnosis.md, "Recovery matrix"): the test
// writes its own deck of the plate tool (its own C3D20R brick mesh from the tool's dimensions), runs
// ccx in a temporary directory, reads its .dat output and makes the same raw DAQ recordings as the
// beam of beam_weight_drop.hpp (daq_recording.hpp), with the same effects built in.
//
// The set-up is the study's (docs/fem.md, "Constraints and the keypoint rule", "Compliant clamp",
// "Calibration-weight simulation"): plate of length L along y (tip y = 0, top y = L), width W along x,
// thickness T along z (centred); elements max(1, round(edge / spacing)) per edge, or `layers`
// through the thickness. Keypoints: the corner nodes on the plate's surface. The clamp fixes every
// DOF of the keypoints with y >= L - clamp_length; the load cell fixes z of the keypoints of the row
// y = L - load_cell_from_top on the back face z = -T/2 and reads the sum of their z reactions; the
// deformation is -u_z averaged over each keypoint row, interpolated linearly between the two rows
// around y = L - sensor_from_top. A compliant clamp (the amount of hidden_effects.hpp's
// clamp_compliance): the springs of the project's compliant clamp (docs/fem.md, "Compliant clamp"),
// the keypoints of the clamp's edge row on the faces pinned in x and z, each held along y by a ground
// spring (SPRING1) of k_theta / sum_j (z_j - z_mid)^2, while the clamp's jaws turn with the edge
// section on them: every other keypoint of the clamp keeps x, and *EQUATIONs give it the edge
// section's rotation theta = (u_y(back) - u_y(front)) / T (u_y linear through the thickness,
// u_z = theta (y - y_edge)). A stiff spring is the rigid clamp (1e7 EI/L: within 1e-6), as the
// beam's root spring is; the project's model leaves the keypoints above the edge free instead, which
// at any spring differs from its rigid clamp (on the narrow tool -2.1 % on the load-cell force).
// The weight m along -z in equal shares on the z DOFs of the keypoints within pan_rows_from_tip of
// the tip (shares moved linearly along y so that their centroid moves load_shift toward the tip),
// its mass (with the unmodelled tip mass, whose weight is tared) lumped on the same z DOFs only: a
// MASS element on a node of its own tied to the pan node's z by an *EQUATION, its x and y fixed.
//
// ccx runs one *FREQUENCY step (the lowest `modes` modes, mass-normalised) and two *STATIC steps
// (the uniform pan load and the shift pattern), printing u at the sensor rows and the pan nodes and
// the load cell's total RF. The response is the exact modal step response with Rayleigh damping per
// mode (Eq 4: C = alpha_s K + beta_per_s M, zeta_j = alpha w_j / 2 + beta / (2 w_j)) plus the modes
// left out, answered without inertia: their displacement z_r = K^-1 F - sum_j phi_j f_j / w_j^2
// follows alpha v' + v = z_r (their stiffness-proportional damping; beta / w^2 neglected, as in
// docs/fem.md, "Modal integration"), so their share of the deformation lags by alpha and their
// share of the load-cell reaction, K_cf (v + alpha v'), is K_cf z_r from the first instant. The
// load cell reads the dynamic support reaction: per mode its static reaction RF_j = K_cf phi_j
// (ccx's RF of the mode shape) times q_j + alpha q_j'; the consistent-mass coupling M_cf of the
// prop's z DOFs (inertia of the elements next to the prop, whose neighbours hardly move) is left
// out.
//
// E enters exactly by scaling: ccx runs at the reference modulus E_ref with the clamp spring
// k_theta E_ref / E, and K(E, k_theta) = (E / E_ref) K(E_ref, k_theta E_ref / E): w_j^2 and RF_j
// times E / E_ref, static displacements times E_ref / E, reactions unchanged. ccx results are cached
// per deck within the process (a deck is the distinct mechanical input: spring, pan mass, mesh).
#pragma once

#include "daq_recording.hpp"

#include <nlohmann/json.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace demfem::campaign::test {

struct CalculixTool {
  double E_Pa = 4.06e9, nu = 0.38, density_kg_m3 = 1220;
  double length_m = 0.200, width_m = 0.010, thickness_m = 0.004;
  double spacing_m = 0.005;  // element edge in plane
  int layers = 0;            // elements through the thickness; 0: max(1, round(T / spacing))
  double clamp_length_m = 0.040, load_cell_from_top_m = 0.065, sensor_from_top_m = 0.093;
  double pan_rows_from_tip_m = 0.010;
  double load_shift_m = 0.0;  // the weight's centroid moved this far toward the tip
  double alpha_s = 0.00055, beta_per_s = 0.0;
  std::optional<double> k_theta_Nm_per_rad;  // none: rigid clamp
  double tip_mass_kg = 0.0;                  // unmodelled: inertia on the pan's z DOFs, no load
  double force_gain = 1.0, deformation_gain = 1.0;
  double force_offset_N = 0.0, deformation_offset_mm = 0.0;
  int modes = 30;
  double reference_E_Pa = 4.06e9;  // the modulus ccx runs at (E by scaling, file comment)

  // Damping ratio of a mode of angular frequency w (Eq 4).
  double dampingRatio(double w) const { return alpha_s * w / 2 + beta_per_s / (2 * w); }

  // EI / L of the free part (clamp edge to tip), the scale of a clamp spring.
  double freeEIoverL() const {
    return E_Pa * width_m * std::pow(thickness_m, 3) / 12 / (length_m - clamp_length_m);
  }
};

// The tool of a study's first tool (a plate) with the study's damping; the weight drop's pan rows.
inline CalculixTool calculixToolFromStudy(const std::filesystem::path& study) {
  std::ifstream in(study);
  if (!in) throw std::runtime_error("cannot read " + study.string());
  const auto j = nlohmann::json::parse(in);
  const auto& tool = j.at("tools").at(0);
  CalculixTool t;
  const auto& g = tool.at("geometry");
  t.length_m = g.at("length_mm").get<double>() / 1000, t.width_m = g.at("width_mm").get<double>() / 1000;
  t.thickness_m = g.at("thickness_mm").get<double>() / 1000, t.spacing_m = g.at("keypoint_spacing_mm").get<double>() / 1000;
  const auto& f = tool.at("fem");
  t.E_Pa = t.reference_E_Pa = f.at("E_Pa").get<double>(), t.nu = f.at("nu").get<double>(), t.density_kg_m3 = f.at("density_kg_m3").get<double>();
  t.alpha_s = f.at("alpha_s").get<double>(), t.beta_per_s = f.value("beta_per_s", 0.0);
  const auto& c = tool.at("constraints");
  t.clamp_length_m = c.at("clamp_length_mm").get<double>() / 1000;
  t.load_cell_from_top_m = c.at("load_cell_from_top_mm").get<double>() / 1000;
  t.sensor_from_top_m = c.at("sensor_from_top_mm").get<double>() / 1000;
  if (c.contains("clamp_rotational_stiffness_Nm_per_rad")) t.k_theta_Nm_per_rad = c.at("clamp_rotational_stiffness_Nm_per_rad").get<double>();
  t.pan_rows_from_tip_m = j.at("weight_drop").at("pan_rows_from_tip_mm").get<double>() / 1000;
  return t;
}

// What ccx gives for one deck, in the load's direction (-z): per mode w^2, the deformation (mm per
// unit modal coordinate), the load cell's RF and the modal force of a unit pan load (uniform, and
// the shift pattern per metre); per pattern the static deformation (mm per N) and load-cell force
// (N per N). At the deck's modulus.
struct CalculixModes {
  Eigen::VectorXd omega2, sensor_mm, reaction_N, modal_force_uniform, modal_force_shift;
  double static_sensor_uniform_mm = 0, static_sensor_shift_mm = 0;
  double static_reaction_uniform = 0, static_reaction_shift = 0;
};

namespace calculix_detail {

// The structured mesh of 20-node bricks: grid points (i, j, k) on the half-element lattice; a node
// where at most one index is odd.
struct Mesh {
  int nx = 0, ny = 0, nz = 0;
  std::vector<int> id;  // node number (1-based) of lattice point, 0 if none
  std::vector<Eigen::Vector3d> position;  // by node number - 1
  int lattice(int i, int j, int k) const { return i + (2 * nx + 1) * (j + (2 * ny + 1) * k); }
  int node(int i, int j, int k) const { return id[static_cast<std::size_t>(lattice(i, j, k))]; }
};

inline Mesh mesh(const CalculixTool& t) {
  Mesh m;
  m.nx = std::max(1, static_cast<int>(std::lround(t.width_m / t.spacing_m)));
  m.ny = std::max(1, static_cast<int>(std::lround(t.length_m / t.spacing_m)));
  m.nz = t.layers > 0 ? t.layers : std::max(1, static_cast<int>(std::lround(t.thickness_m / t.spacing_m)));
  m.id.assign(static_cast<std::size_t>((2 * m.nx + 1) * (2 * m.ny + 1) * (2 * m.nz + 1)), 0);
  for (int k = 0; k <= 2 * m.nz; ++k)
    for (int j = 0; j <= 2 * m.ny; ++j)
      for (int i = 0; i <= 2 * m.nx; ++i)
        if ((i % 2) + (j % 2) + (k % 2) <= 1) {
          m.position.emplace_back(-t.width_m / 2 + i * t.width_m / (2 * m.nx), j * t.length_m / (2 * m.ny), -t.thickness_m / 2 + k * t.thickness_m / (2 * m.nz));
          m.id[static_cast<std::size_t>(m.lattice(i, j, k))] = static_cast<int>(m.position.size());
        }
  return m;
}

// Keypoints: corner nodes on the surface, by row (y ascending).
struct Keypoint {
  int node;
  Eigen::Vector3d x;
};
inline std::vector<std::vector<Keypoint>> keypointRows(const Mesh& m) {
  std::vector<std::vector<Keypoint>> rows(static_cast<std::size_t>(m.ny + 1));
  for (int j = 0; j <= 2 * m.ny; j += 2)
    for (int k = 0; k <= 2 * m.nz; k += 2)
      for (int i = 0; i <= 2 * m.nx; i += 2)
        if (i == 0 || i == 2 * m.nx || j == 0 || j == 2 * m.ny || k == 0 || k == 2 * m.nz) {
          const int n = m.node(i, j, k);
          rows[static_cast<std::size_t>(j / 2)].push_back({n, m.position[static_cast<std::size_t>(n - 1)]});
        }
  return rows;
}

inline std::size_t rowAt(const CalculixTool& t, const Mesh& m, double y, const char* what) {
  const double r = y / (t.length_m / m.ny);
  if (std::abs(r - std::round(r)) > 1e-6) throw std::invalid_argument(std::string(what) + " is not on a keypoint row");
  return static_cast<std::size_t>(std::lround(r));
}

inline void nodeSet(std::ostream& out, const std::string& name, const std::vector<int>& nodes) {
  out << "*NSET, NSET=" << name << "\n";
  for (std::size_t i = 0; i < nodes.size(); ++i) out << nodes[i] << ((i % 10 == 9 || i + 1 == nodes.size()) ? "\n" : ", ");
}

// The sensor's two rows and weights, the pan's nodes and load shares (uniform, shift per metre).
struct Layout {
  std::size_t sensor_row[2];
  double sensor_weight[2];
  std::vector<int> pan;
  std::vector<double> pan_shift;  // share change per metre of centroid shift
};

inline Layout layout(const CalculixTool& t, const Mesh& m, const std::vector<std::vector<Keypoint>>& rows) {
  Layout l;
  const double h = t.length_m / m.ny, y = t.length_m - t.sensor_from_top_m;
  const auto below = static_cast<std::size_t>(std::floor(y / h + 1e-9));
  l.sensor_row[0] = below, l.sensor_row[1] = std::min(below + 1, rows.size() - 1);
  l.sensor_weight[1] = y / h - static_cast<double>(below), l.sensor_weight[0] = 1 - l.sensor_weight[1];
  std::vector<double> ys;
  for (const auto& row : rows)
    for (const Keypoint& k : row)
      if (k.x.y() <= t.pan_rows_from_tip_m + 1e-9) l.pan.push_back(k.node), ys.push_back(k.x.y());
  double mean = 0, spread = 0;
  for (double v : ys) mean += v / static_cast<double>(ys.size());
  for (double v : ys) spread += (v - mean) * (v - mean);
  for (double v : ys) l.pan_shift.push_back(spread > 0 ? -(v - mean) / spread : 0.0);  // toward the tip: smaller y
  return l;
}

// The deck at t.reference_E_Pa with the clamp spring k_theta E_ref / E and `pan_mass_kg` on the pan.
inline std::string deck(const CalculixTool& t, double pan_mass_kg) {
  const Mesh m = mesh(t);
  const auto rows = keypointRows(m);
  const Layout l = layout(t, m, rows);
  std::ostringstream d;
  d.precision(17);
  d << "*HEADING\ndemfem test: weight drop of a plate tool\n*NODE, NSET=NALL\n";
  for (std::size_t n = 0; n < m.position.size(); ++n) d << n + 1 << ", " << m.position[n].x() << ", " << m.position[n].y() << ", " << m.position[n].z() << "\n";
  const int mass_nodes = static_cast<int>(m.position.size());
  d << "*NODE, NSET=PANMASS\n";
  for (std::size_t p = 0; p < l.pan.size(); ++p) {
    const Eigen::Vector3d& x = m.position[static_cast<std::size_t>(l.pan[p] - 1)];
    d << mass_nodes + static_cast<int>(p) + 1 << ", " << x.x() << ", " << x.y() << ", " << x.z() << "\n";
  }
  // C3D20R node order: corners of z-, corners of z+, mid-edges of z-, of z+, the vertical mid-edges.
  static const int corner[8][3] = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {0, 0, 2}, {2, 0, 2}, {2, 2, 2}, {0, 2, 2}};
  static const int edge[12][3] = {{1, 0, 0}, {2, 1, 0}, {1, 2, 0}, {0, 1, 0}, {1, 0, 2}, {2, 1, 2}, {1, 2, 2}, {0, 1, 2}, {0, 0, 1}, {2, 0, 1}, {2, 2, 1}, {0, 2, 1}};
  d << "*ELEMENT, TYPE=C3D20R, ELSET=EALL\n";
  int element = 0;
  for (int ez = 0; ez < m.nz; ++ez)
    for (int ey = 0; ey < m.ny; ++ey)
      for (int ex = 0; ex < m.nx; ++ex) {
        d << ++element;
        int a = 0;
        for (const auto& c : corner) d << ", " << m.node(2 * ex + c[0], 2 * ey + c[1], 2 * ez + c[2]), ++a;
        for (const auto& c : edge) d << (a == 15 ? ",\n" : ", ") << m.node(2 * ex + c[0], 2 * ey + c[1], 2 * ez + c[2]), ++a;
        d << "\n";
      }
  d << "*ELEMENT, TYPE=MASS, ELSET=EMASS\n";
  for (std::size_t p = 0; p < l.pan.size(); ++p) d << ++element << ", " << mass_nodes + static_cast<int>(p) + 1 << "\n";
  const std::size_t edge_row = rowAt(t, m, t.length_m - t.clamp_length_m, "the clamp edge");
  const std::size_t cell_row = rowAt(t, m, t.length_m - t.load_cell_from_top_m, "the load-cell line");
  const double half = t.thickness_m / 2;
  std::vector<int> clamp, faces, jaws, load_cell, sensor[2];
  for (std::size_t r = edge_row; r < rows.size(); ++r)
    for (const Keypoint& k : rows[r])
      (!t.k_theta_Nm_per_rad ? clamp : r == edge_row && std::abs(k.x.z()) > half - 1e-12 ? faces : jaws).push_back(k.node);
  for (const Keypoint& k : rows[cell_row])
    if (std::abs(k.x.z() + half) < 1e-12) load_cell.push_back(k.node);
  for (int s = 0; s < 2; ++s)
    for (const Keypoint& k : rows[l.sensor_row[s]]) sensor[s].push_back(k.node);
  if (t.k_theta_Nm_per_rad) {
    double sum_z2 = 0;
    for (int n : faces) sum_z2 += std::pow(m.position[static_cast<std::size_t>(n - 1)].z(), 2);
    const double k_spring = *t.k_theta_Nm_per_rad * t.reference_E_Pa / t.E_Pa / sum_z2;
    d << "*ELEMENT, TYPE=SPRING1, ELSET=ESPRING\n";
    for (int n : faces) d << ++element << ", " << n << "\n";
    d << "*SPRING, ELSET=ESPRING\n2\n" << k_spring << "\n";
  }
  nodeSet(d, "CLAMP", t.k_theta_Nm_per_rad ? faces : clamp);
  if (!jaws.empty()) nodeSet(d, "JAWS", jaws);
  nodeSet(d, "LOADCELL", load_cell);
  nodeSet(d, "SENSOR0", sensor[0]);
  nodeSet(d, "SENSOR1", sensor[1]);
  nodeSet(d, "PAN", l.pan);
  d << "*BOUNDARY\n" << (t.k_theta_Nm_per_rad ? "CLAMP, 1, 1\nCLAMP, 3, 3\n" : "CLAMP, 1, 3\n") << (jaws.empty() ? "" : "JAWS, 1, 1\n")
    << "LOADCELL, 3, 3\nPANMASS, 1, 2\n";
  // One linear constraint: the first term's DOF follows the others (terms with a zero coefficient left out).
  const auto equation = [&d](std::vector<std::tuple<int, int, double>> terms) {
    std::erase_if(terms, [](const auto& term) { return std::get<2>(term) == 0; });
    d << terms.size() << "\n";
    for (std::size_t i = 0; i < terms.size(); ++i) d << std::get<0>(terms[i]) << ", " << std::get<1>(terms[i]) << ", " << std::get<2>(terms[i]) << (i + 1 == terms.size() ? "\n" : ", ");
  };
  d << "*EQUATION\n";
  for (std::size_t p = 0; p < l.pan.size(); ++p) equation({{mass_nodes + static_cast<int>(p) + 1, 3, 1.0}, {l.pan[p], 3, -1.0}});
  // The jaws turn with the edge section: the edge's face nodes at the same x give its rotation,
  // theta = (u_y(back) - u_y(front)) / T; u_y varies linearly through the thickness and
  // u_z = theta (y - y_edge).
  const double y_edge = t.length_m - t.clamp_length_m;
  for (int n : jaws) {
    const Eigen::Vector3d& x = m.position[static_cast<std::size_t>(n - 1)];
    const int i = static_cast<int>(std::lround((x.x() + t.width_m / 2) / (t.width_m / (2 * m.nx)))), j = 2 * static_cast<int>(edge_row);
    const int back = m.node(i, j, 0), front = m.node(i, j, 2 * m.nz);
    const double s_front = (x.z() + half) / t.thickness_m, c = (x.y() - y_edge) / t.thickness_m;
    equation({{n, 2, 1.0}, {back, 2, -(1 - s_front)}, {front, 2, -s_front}});
    if (c > 0)
      equation({{n, 3, 1.0}, {back, 2, -c}, {front, 2, c}});
    else
      d << "*BOUNDARY\n" << n << ", 3, 3\n";  // on the edge row, between its faces: pinned like them
  }
  d << "*MATERIAL, NAME=TOOL\n*ELASTIC\n" << t.reference_E_Pa << ", " << t.nu << "\n*DENSITY\n" << t.density_kg_m3 << "\n";
  d << "*SOLID SECTION, ELSET=EALL, MATERIAL=TOOL\n*MASS, ELSET=EMASS\n" << pan_mass_kg / static_cast<double>(l.pan.size()) << "\n";
  const auto print = [&] { d << "*NODE PRINT, NSET=SENSOR0\nU\n*NODE PRINT, NSET=SENSOR1\nU\n*NODE PRINT, NSET=PAN\nU\n*NODE PRINT, NSET=LOADCELL, TOTALS=ONLY\nRF\n"; };
  d << "*STEP\n*FREQUENCY\n" << t.modes << "\n";
  print();
  d << "*END STEP\n";
  for (int pattern = 0; pattern < 2; ++pattern) {
    d << "*STEP\n*STATIC\n*CLOAD, OP=NEW\n";
    for (std::size_t p = 0; p < l.pan.size(); ++p)
      d << l.pan[p] << ", 3, " << -(pattern == 0 ? 1.0 / static_cast<double>(l.pan.size()) : l.pan_shift[p]) << "\n";
    print();
    d << "*END STEP\n";
  }
  return d.str();
}

// One block of a .dat file: a header line and the rows of numbers after it.
struct DatBlock {
  std::string header;
  std::vector<std::vector<double>> rows;
};

inline std::vector<DatBlock> datBlocks(std::istream& in) {
  std::vector<DatBlock> blocks;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::vector<double> v;
    double x = 0;
    while (s >> x) v.push_back(x);
    if (!v.empty() && s.eof()) {
      if (!blocks.empty()) blocks.back().rows.push_back(std::move(v));
    } else if (line.find_first_not_of(" \t\r") != std::string::npos) {
      blocks.push_back({line, {}});
    }
  }
  return blocks;
}

inline CalculixModes runDeck(const std::string& text, const CalculixTool& t) {
  std::string pattern = (std::filesystem::temp_directory_path() / "demfem_ccx_XXXXXX").string();
  if (!mkdtemp(pattern.data())) throw std::runtime_error("cannot make a temporary directory for ccx");
  const std::filesystem::path dir(pattern);
  std::ofstream(dir / "tool.inp") << text;
  const std::string command = "cd '" + dir.string() + "' && OMP_NUM_THREADS=1 ccx -i tool > ccx.log 2>&1";
  const int rc = std::system(command.c_str());
  std::ifstream dat(dir / "tool.dat");
  if (rc != 0 || !dat) throw std::runtime_error("ccx failed in " + dir.string() + " (see ccx.log there)");
  const auto blocks = datBlocks(dat);
  // Order: eigenvalues, then per mode SENSOR0, SENSOR1, PAN, LOADCELL; then per static step the same.
  const Mesh m = mesh(t);
  const Layout l = layout(t, m, keypointRows(m));
  CalculixModes r;
  std::vector<double> omega2;
  std::size_t b = 0;
  for (; b < blocks.size(); ++b)
    if (blocks[b].header.find("E I G E N V A L U E   O U T P U T") != std::string::npos) break;
  // The eigenvalue table: the block after the column headings whose rows are (mode, eigenvalue, ...).
  for (++b; b < blocks.size() && omega2.empty(); ++b)
    for (const auto& row : blocks[b].rows)
      if (row.size() >= 4) omega2.push_back(row[1]);
  if (static_cast<int>(omega2.size()) != t.modes) throw std::runtime_error("ccx gave " + std::to_string(omega2.size()) + " modes in " + dir.string());
  const auto mean_uz = [](const DatBlock& block) {
    double s = 0;
    for (const auto& row : block.rows) s += row.at(3);
    return s / static_cast<double>(block.rows.size());
  };
  const auto pan_dot = [&](const DatBlock& block, const std::vector<double>& shares) {
    double s = 0;
    for (std::size_t p = 0; p < l.pan.size(); ++p) {
      const auto& row = block.rows.at(p);
      if (static_cast<int>(row.at(0)) != l.pan[p]) throw std::runtime_error("ccx: unexpected node order in the pan's output");
      s += -row.at(3) * shares[p];  // unit load along -z
    }
    return s;
  };
  std::vector<DatBlock> sets;
  for (; b < blocks.size(); ++b)
    if (blocks[b].header.find("for set") != std::string::npos) sets.push_back(blocks[b]);
  if (sets.size() != 4 * static_cast<std::size_t>(t.modes + 2)) throw std::runtime_error("ccx: unexpected output blocks in " + dir.string());
  // The deformation and the load cell's z reaction of the displacement of the four blocks from `first`.
  const auto sensor_mm = [&](std::size_t first) { return -1000 * (l.sensor_weight[0] * mean_uz(sets[first]) + l.sensor_weight[1] * mean_uz(sets[first + 1])); };
  const auto reaction = [&](std::size_t first) { return sets[first + 3].rows.at(0).at(2); };
  const std::vector<double> uniform(l.pan.size(), 1.0 / static_cast<double>(l.pan.size()));
  const auto n = static_cast<Eigen::Index>(t.modes);
  r.omega2 = Eigen::Map<const Eigen::VectorXd>(omega2.data(), n);
  r.sensor_mm.resize(n), r.reaction_N.resize(n), r.modal_force_uniform.resize(n), r.modal_force_shift.resize(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const auto first = 4 * static_cast<std::size_t>(j);
    r.sensor_mm(j) = sensor_mm(first), r.reaction_N(j) = reaction(first);
    r.modal_force_uniform(j) = pan_dot(sets[first + 2], uniform), r.modal_force_shift(j) = pan_dot(sets[first + 2], l.pan_shift);
  }
  const auto statics = 4 * static_cast<std::size_t>(t.modes);
  r.static_sensor_uniform_mm = sensor_mm(statics), r.static_reaction_uniform = reaction(statics);
  r.static_sensor_shift_mm = sensor_mm(statics + 4), r.static_reaction_shift = reaction(statics + 4);
  std::filesystem::remove_all(dir);
  return r;
}

}  // namespace calculix_detail

// The tool's modes and static responses with `pan_mass_kg` (weight and unmodelled mass) on the pan,
// at the tool's modulus (E by scaling, file comment); ccx runs once per distinct deck per process.
inline CalculixModes calculixModes(const CalculixTool& t, double pan_mass_kg) {
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<std::once_flag>> flags;
  static std::map<std::string, CalculixModes> cache;
  const std::string text = calculix_detail::deck(t, pan_mass_kg);
  std::shared_ptr<std::once_flag> flag;
  {
    const std::lock_guard lock(mutex);
    auto& f = flags[text];
    if (!f) f = std::make_shared<std::once_flag>();
    flag = f;
  }
  std::call_once(*flag, [&] {
    CalculixModes r = calculix_detail::runDeck(text, t);
    const std::lock_guard lock(mutex);
    cache[text] = std::move(r);
  });
  CalculixModes r;
  {
    const std::lock_guard lock(mutex);
    r = cache.at(text);
  }
  const double e = t.E_Pa / t.reference_E_Pa;
  r.omega2 *= e, r.reaction_N *= e;
  r.static_sensor_uniform_mm /= e, r.static_sensor_shift_mm /= e;
  return r;
}

// The true channels of the weight `mass_kg` hung at t = 0 (t_after_drop: time since then, 0 before).
inline ChannelResponse calculixWeightDrop(const CalculixTool& t, double mass_kg, const std::vector<double>& t_after_drop) {
  const CalculixModes m = calculixModes(t, mass_kg + t.tip_mass_kg);
  const double load = mass_kg * kStandardGravity_m_s2, shift = t.load_shift_m;
  const Eigen::VectorXd f = load * (m.modal_force_uniform + shift * m.modal_force_shift);
  const double static_sensor = load * (m.static_sensor_uniform_mm + shift * m.static_sensor_shift_mm);
  const double static_reaction = load * (m.static_reaction_uniform + shift * m.static_reaction_shift);
  // The modes left out (file comment): their static share of each channel.
  double rest_sensor = static_sensor, rest_reaction = static_reaction;
  for (Eigen::Index j = 0; j < m.omega2.size(); ++j) rest_sensor -= m.sensor_mm(j) * f(j) / m.omega2(j), rest_reaction -= m.reaction_N(j) * f(j) / m.omega2(j);
  ChannelResponse r;
  for (double tau : t_after_drop) {
    double sensor = rest_sensor * (t.alpha_s > 0 ? 1 - std::exp(-tau / t.alpha_s) : 1.0), reaction = rest_reaction;
    for (Eigen::Index j = 0; j < m.omega2.size(); ++j) {
      const double w = std::sqrt(m.omega2(j));
      const ModalState s = modalStep(m.omega2(j), t.dampingRatio(w), f(j), tau);
      sensor += m.sensor_mm(j) * s.q;
      reaction += m.reaction_N(j) * (s.q + t.alpha_s * s.qd);
    }
    r.t_s.push_back(tau);
    r.force_N.push_back(reaction * t.force_gain + t.force_offset_N);
    r.deformation_mm.push_back(sensor * t.deformation_gain + t.deformation_offset_mm);
  }
  return r;
}

// The raw recording of one weight hung on the tool.
inline analysis::SyntheticRecording calculixRecording(const CalculixTool& t, double mass_kg, const Daq& daq, int repeat = 1) {
  return daqRecording(calculixWeightDrop(t, mass_kg, daq.timesAfterDrop_s()), mass_kg, daq, repeat);
}

}  // namespace demfem::campaign::test
