#include "demfem/fem/weight_drop.hpp"

#include "demfem/fem/integrator.hpp"
#include "demfem/fem/sensors.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace demfem::fem {
namespace {

struct Peak {
  double t;      // interpolated time of the maximum (in samples)
  double value;  // interpolated value
};

// Local maxima above `floor`, refined by a parabola through the three samples around each.
std::vector<Peak> maximaAbove(const std::vector<double>& v, double floor) {
  std::vector<Peak> peaks;
  for (std::size_t i = 1; i + 1 < v.size(); ++i) {
    if (!(v[i] > v[i - 1] && v[i] >= v[i + 1] && v[i] > floor)) continue;
    const double a = v[i - 1], b = v[i], c = v[i + 1];
    const double curvature = a - 2 * b + c;
    const double shift = curvature < 0 ? 0.5 * (a - c) / curvature : 0.0;
    peaks.push_back({static_cast<double>(i) + shift, b - 0.25 * (a - c) * shift});
  }
  return peaks;
}

}  // namespace

SignalCharacteristics characterize(const std::vector<double>& values, double dt_s) {
  if (values.size() < 3 || !(dt_s > 0)) throw std::invalid_argument("characterize: need at least 3 samples and dt > 0");
  SignalCharacteristics c;
  const std::size_t tail = values.size() - values.size() / 3;
  double sum = 0;
  for (std::size_t i = tail; i < values.size(); ++i) sum += values[i];
  c.steady = sum / static_cast<double>(values.size() - tail);
  std::vector<Peak> peaks = maximaAbove(values, c.steady);
  // Keep the oscillation well above round-off: amplitudes down to 1e-6 of the first one.
  if (!peaks.empty()) {
    const double first = peaks.front().value - c.steady;
    std::size_t keep = 0;
    while (keep < peaks.size() && peaks[keep].value - c.steady > 1e-6 * first) ++keep;
    peaks.resize(keep);
  }
  c.maxima = static_cast<int>(peaks.size());
  if (peaks.size() < 2) return c;
  double frequency_sum = 0, zeta_sum = 0;
  for (std::size_t k = 0; k + 1 < peaks.size(); ++k) {
    frequency_sum += 1 / ((peaks[k + 1].t - peaks[k].t) * dt_s);
    const double delta = std::log((peaks[k].value - c.steady) / (peaks[k + 1].value - c.steady));
    zeta_sum += delta / std::sqrt(4 * std::numbers::pi * std::numbers::pi + delta * delta);
  }
  c.frequency_Hz = frequency_sum / static_cast<double>(peaks.size() - 1);
  c.damping_ratio = zeta_sum / static_cast<double>(peaks.size() - 1);
  return c;
}

WeightDropResult simulateWeightDrop(const ReducedModel& model, const study::Tool& tool, const study::WeightDrop& drop,
                                    double dt_s, const std::function<void(double)>& progress) {
  if (!(drop.mass_kg > 0)) throw std::invalid_argument("weight drop: mass must be > 0 kg");
  if (!(drop.duration_s > 0)) throw std::invalid_argument("weight drop: duration must be > 0 s");
  const double tip = model.keypoints.col(1).minCoeff();
  std::vector<int> pan_z_dofs;
  for (int k = 0; k < model.keypointCount(); ++k)
    if (model.keypoints(k, 1) <= tip + drop.pan_rows_from_tip_m + 1e-9) pan_z_dofs.push_back(3 * k + 2);
  if (pan_z_dofs.empty())
    throw std::invalid_argument("weight drop: no keypoint row within pan_rows_from_tip = " + std::to_string(drop.pan_rows_from_tip_m) +
                                " m of the tip");
  const auto n = static_cast<double>(pan_z_dofs.size());
  // Section 2.10.1: the weight as a uniform load on the pan rows (gravity along -z of the tool) ...
  Eigen::VectorXd load = Eigen::VectorXd::Zero(model.dofCount());
  for (int dof : pan_z_dofs) load(dof) = -drop.mass_kg * kStandardGravity_m_s2 / n;
  // ... and its mass lumped on the diagonal of M in the same rows, with the added mass already
  // hanging there (its weight tared: no load).
  ReducedModel loaded = model;
  addLumpedMass(loaded, pan_z_dofs, (drop.mass_kg + drop.added_mass_kg) / n);

  const Sensors sensors(loaded, tool);
  WeightDropResult result;
  result.pan_keypoints = static_cast<int>(pan_z_dofs.size());
  const StaticSolution static_solution = solveStatic(loaded, load);
  const SensorReadings static_reading = sensors.read(static_solution.displacement, static_solution.reaction);
  result.static_force_N = static_reading.load_cell_N;
  result.static_deformation_mm = static_reading.deformation_mm;

  ThreeLevelIntegrator integrator(loaded, dt_s, {tool.fem.alpha_s, tool.fem.beta_per_s});
  integrator.start(Eigen::VectorXd::Zero(loaded.dofCount()));  // at rest, tool weight tared
  const auto steps = static_cast<long>(std::llround(drop.duration_s / dt_s));
  result.samples.push_back({0, 0, 0});
  for (long i = 1; i <= steps; ++i) {
    integrator.step(load);  // the weight hangs from t = dt on
    const SensorReadings r = sensors.read(integrator.displacement(), integrator.reactions());
    result.samples.push_back({integrator.time(), r.load_cell_N, r.deformation_mm});
    if (progress && (i % 50 == 0 || i == steps)) progress(static_cast<double>(i) / static_cast<double>(steps));
  }
  std::vector<double> force, deformation;
  for (const auto& s : result.samples) force.push_back(s.force_N), deformation.push_back(s.deformation_mm);
  result.force = characterize(force, dt_s);
  result.deformation = characterize(deformation, dt_s);
  return result;
}

void writeWeightDropCsv(std::ostream& out, const WeightDropResult& result) {
  out << "t_s,force_N,deformation_mm\n";
  out.precision(10);
  for (const auto& s : result.samples) out << s.t_s << "," << s.force_N << "," << s.deformation_mm << "\n";
}

}  // namespace demfem::fem
