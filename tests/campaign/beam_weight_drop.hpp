// Test fixture: calibration-weight recordings from a model INDEPENDENT of the project's FEM code: an
// Euler-Bernoulli beam of the tool's free part (Hermite cubic elements, consistent mass, its own
// eigen solution and an exact modal step response), with the effects a diagnosis must find built
// in: a rotational spring at the clamp edge, Rayleigh damping C = alpha K + beta M (Eq 4: alpha_s
// multiplies K, beta_per_s multiplies M), an unmodelled mass at the tip, and a gain and an offset
// on each of the two channels. Written as a raw DAQ recording (daq_recording.hpp, shared with the
// CalculiX generator of calculix_weight_drop.hpp).
//
// Beam: x from the clamp's lower edge (x = 0) to the tip (x = free_length). w(0) = 0; the root
// rotation is fixed (rigid clamp) or held by the spring k_theta; the load cell holds w(prop) = 0 and
// reads the support force. The pan: the weight m g in equal parts on the nodes within pan_length of
// the tip, its mass lumped there. The unmodelled tip mass is lumped on the same nodes but carries
// no load: it hangs on the tool before the weight (e.g. a hook), so the tare removes its weight and
// only its inertia remains. The weight's shares on the pan nodes can be moved linearly so that their
// centroid moves toward the tip (a weight hung a little off the pan's centre). Deformation: w at the sensor, interpolated with the element's shape
// functions. The tool's own weight is tared, so the readings are the response to the weight; a
// channel's offset is added to its reading from the moment the weight is hung (a zero shift of
// the loaded sensor, the same at every weight), its gain multiplies the response.
#pragma once

#include "daq_recording.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

namespace demfem::campaign::test {

struct BeamTool {
  double E_Pa = 4.06e9, density_kg_m3 = 1220, width_m = 0.010, thickness_m = 0.004;
  double free_length_m = 0.160;      // tip to clamp edge
  double prop_from_edge_m = 0.025;   // load cell
  double sensor_from_edge_m = 0.053; // deformation sensor
  double pan_length_m = 0.010;       // nodes within this distance of the tip carry the weight
  double load_shift_m = 0.0;         // the weight's centroid moved this far toward the tip
  double element_m = 0.005;
  double alpha_s = 0.00055, beta_per_s = 0.0;
  std::optional<double> k_theta_Nm_per_rad;  // none: rigid clamp
  double tip_mass_kg = 0.0;                  // unmodelled: inertia on the pan nodes, no load
  double force_gain = 1.0, deformation_gain = 1.0;
  double force_offset_N = 0.0, deformation_offset_mm = 0.0;
};

// The beam with one weight hung: its free DOFs' modes (M-normalised), the modal load, and the rows
// that read the two channels.
struct BeamModes {
  Eigen::MatrixXd phi;
  Eigen::VectorXd omega2, modal_force;
  Eigen::RowVectorXd sensor, Kp, Mp;  // deformation row; the load cell's rows of K and M
  double alpha_s = 0, beta_per_s = 0;

  // Damping ratio of mode j (Eq 4, modal): zeta = alpha omega / 2 + beta / (2 omega).
  double zeta(Eigen::Index j) const {
    const double w = std::sqrt(omega2(j));
    return alpha_s * w / 2 + beta_per_s / (2 * w);
  }
};

inline BeamModes beamModes(const BeamTool& b, double mass_kg) {
  const int elements = static_cast<int>(std::lround(b.free_length_m / b.element_m));
  const double h = b.free_length_m / elements;
  const int nodes = elements + 1, n = 2 * nodes;  // DOFs (w, theta) per node, node 0 at the clamp edge
  const double EI = b.E_Pa * b.width_m * std::pow(b.thickness_m, 3) / 12;
  const double rhoA = b.density_kg_m3 * b.width_m * b.thickness_m;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n), M = Eigen::MatrixXd::Zero(n, n);
  Eigen::Matrix4d ke, me;
  ke << 12, 6 * h, -12, 6 * h, 6 * h, 4 * h * h, -6 * h, 2 * h * h, -12, -6 * h, 12, -6 * h, 6 * h, 2 * h * h, -6 * h, 4 * h * h;
  me << 156, 22 * h, 54, -13 * h, 22 * h, 4 * h * h, 13 * h, -3 * h * h, 54, 13 * h, 156, -22 * h, -13 * h, -3 * h * h, -22 * h, 4 * h * h;
  ke *= EI / (h * h * h);
  me *= rhoA * h / 420;
  for (int e = 0; e < elements; ++e) K.block(2 * e, 2 * e, 4, 4) += ke, M.block(2 * e, 2 * e, 4, 4) += me;
  if (b.k_theta_Nm_per_rad) K(1, 1) += *b.k_theta_Nm_per_rad;
  const int prop = static_cast<int>(std::lround(b.prop_from_edge_m / h));
  Eigen::VectorXd F = Eigen::VectorXd::Zero(n);
  std::vector<int> pan;
  for (int i = 0; i < nodes; ++i)
    if (b.free_length_m - i * h <= b.pan_length_m + 1e-9) pan.push_back(i);
  // Equal shares, moved linearly along the pan so that their centroid moves by load_shift_m.
  double mean_x = 0, spread = 0;
  for (int i : pan) mean_x += i * h / static_cast<double>(pan.size());
  for (int i : pan) spread += std::pow(i * h - mean_x, 2);
  for (int i : pan) {
    const double share = 1.0 / static_cast<double>(pan.size()) + (spread > 0 ? b.load_shift_m * (i * h - mean_x) / spread : 0.0);
    F(2 * i) = mass_kg * kStandardGravity_m_s2 * share, M(2 * i, 2 * i) += (mass_kg + b.tip_mass_kg) * share;
  }
  std::vector<int> fixed{0, 2 * prop}, free;
  if (!b.k_theta_Nm_per_rad) fixed.push_back(1);
  for (int d = 0; d < n; ++d)
    if (std::find(fixed.begin(), fixed.end(), d) == fixed.end()) free.push_back(d);
  const Eigen::MatrixXd Kff = K(free, free), Mff = M(free, free);
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(Kff, Mff);
  BeamModes m;
  m.phi = eig.eigenvectors();  // M-normalised, ascending frequency
  m.omega2 = eig.eigenvalues();
  m.modal_force = m.phi.transpose() * F(free);
  m.alpha_s = b.alpha_s, m.beta_per_s = b.beta_per_s;
  // Sensor row: w interpolated in the element holding the sensor.
  const int se = std::min(elements - 1, static_cast<int>(b.sensor_from_edge_m / h));
  const double xi = b.sensor_from_edge_m / h - se;
  Eigen::VectorXd sensor = Eigen::VectorXd::Zero(n);
  sensor(2 * se) = 1 - 3 * xi * xi + 2 * xi * xi * xi;
  sensor(2 * se + 1) = h * (xi - 2 * xi * xi + xi * xi * xi);
  sensor(2 * se + 2) = 3 * xi * xi - 2 * xi * xi * xi;
  sensor(2 * se + 3) = h * (-xi * xi + xi * xi * xi);
  m.sensor = sensor(free).transpose();
  // The load cell's force on the beam balances the prop row of K u + C u' + M u'' (minus no load).
  m.Kp = K.row(2 * prop)(free);
  m.Mp = M.row(2 * prop)(free);
  return m;
}

inline ChannelResponse beamWeightDrop(const BeamTool& b, double mass_kg, const std::vector<double>& t_after_drop) {
  const BeamModes m = beamModes(b, mass_kg);
  const Eigen::Index modes = m.omega2.size();
  ChannelResponse r;
  for (double t : t_after_drop) {
    Eigen::VectorXd q(modes), qd(modes), qdd(modes);
    for (Eigen::Index j = 0; j < modes; ++j) {
      const ModalState s = modalStep(m.omega2(j), m.zeta(j), m.modal_force(j), t);
      q(j) = s.q, qd(j) = s.qd, qdd(j) = s.qdd;
    }
    const Eigen::VectorXd u = m.phi * q, ud = m.phi * qd, udd = m.phi * qdd;
    const double damping = b.alpha_s * m.Kp.dot(ud) + b.beta_per_s * m.Mp.dot(ud);
    r.t_s.push_back(t);
    r.force_N.push_back(-(m.Kp.dot(u) + damping + m.Mp.dot(udd)) * b.force_gain + b.force_offset_N);
    r.deformation_mm.push_back(1000 * m.sensor.dot(u) * b.deformation_gain + b.deformation_offset_mm);
  }
  return r;
}

// The raw recording of one weight hung on beam `b`.
inline analysis::SyntheticRecording beamRecording(const BeamTool& b, double mass_kg, const Daq& daq, int repeat = 1) {
  return daqRecording(beamWeightDrop(b, mass_kg, daq.timesAfterDrop_s()), mass_kg, daq, repeat);
}

}  // namespace demfem::campaign::test
