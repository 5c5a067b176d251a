#include "demfem/campaign/objective.hpp"

#include <algorithm>
#include <cmath>

namespace demfem::campaign {
namespace {

double withFloor(double sigma, double measured, const ObjectiveSettings& s) {
  return std::max(sigma, s.relative_floor * std::abs(measured));
}

double standardError(const analysis::SignalStatistics& s) {
  return s.samples > 0 ? s.std_dev / std::sqrt(static_cast<double>(s.samples)) : 0.0;
}

// Samples in the steady tail of a run of `size` samples (step_response.hpp).
std::size_t tailSamples(std::size_t size, const analysis::StepResponseSettings& s) {
  const auto fraction = static_cast<std::size_t>(s.steady_fraction * static_cast<double>(size));
  return std::min(size, std::max(s.min_tail_samples, fraction));
}

void addCalibrationTargets(const analysis::CalibrationCase& c, const analysis::EvaluationResult& measured, const ObjectiveSettings& s,
                           std::vector<Target>& out) {
  double force_error = 0, deformation_error = 0;  // largest standard error of a repeat's steady value
  for (const auto& run : measured.calibration_runs) {
    if (run.key != c.key) continue;
    const double root_n = std::sqrt(static_cast<double>(tailSamples(run.time_s.size(), s.analysis.step_response)));
    force_error = std::max(force_error, run.force.steady_std / root_n);
    deformation_error = std::max(deformation_error, run.deformation.steady_std / root_n);
  }
  const auto steady = [&](const char* name, const analysis::SignalStatistics& st, double run_error) {
    const double between = st.samples > 1 ? st.std_dev : 0.0;
    out.push_back({c.key, name, st.mean, withFloor(std::max(between, run_error), st.mean, s)});
  };
  steady("steady_force_N", c.force.steady, force_error);
  steady("steady_deformation_mm", c.deformation.steady, deformation_error);
  out.push_back({c.key, "frequency_Hz", c.deformation.frequency_Hz.mean,
                 withFloor(standardError(c.deformation.frequency_Hz), c.deformation.frequency_Hz.mean, s)});
  out.push_back({c.key, "damping_ratio", c.deformation.damping_ratio.mean,
                 withFloor(standardError(c.deformation.damping_ratio), c.deformation.damping_ratio.mean, s)});
}

void addSoilTargets(const analysis::PooledCase& c, const analysis::EvaluationResult& measured, const ObjectiveSettings& s,
                    std::vector<Target>& out) {
  std::size_t samples = 0;
  for (const auto& run : measured.soil_bin_runs)
    if (run.key == c.key) samples += run.window.force_N.samples;
  const double root_n = std::sqrt(static_cast<double>(std::max<std::size_t>(samples, 1)));
  const double spread_factor = 1 / std::sqrt(2.0 * static_cast<double>(std::max<std::size_t>(samples, 2) - 1));
  const auto signal = [&](const std::string& name, double mean, const std::optional<double>& between, double spread) {
    out.push_back({c.key, "window_mean_" + name, mean, withFloor(std::max(between.value_or(0.0), spread / root_n), mean, s)});
    out.push_back({c.key, "window_std_" + name, spread, withFloor(spread * spread_factor, spread, s)});
  };
  signal("force_N", c.force_mean_N, c.force_between_repeats_std_N, c.force_std_N);
  if (s.soil_deformation) signal("deformation_mm", c.deformation_mean_mm, c.deformation_between_repeats_std_mm, c.deformation_std_mm);
}

// The simulated value of `quantity` for the case, if it could be evaluated.
std::optional<double> simulatedValue(const analysis::EvaluationResult& sim, const Target& t) {
  for (const auto& c : sim.calibration_cases) {
    if (c.key != t.key) continue;
    if (t.quantity == "steady_force_N") return c.force.steady.mean;
    if (t.quantity == "steady_deformation_mm") return c.deformation.steady.mean;
    if (t.quantity == "frequency_Hz") return c.deformation.frequency_Hz.mean;
    if (t.quantity == "damping_ratio") return c.deformation.damping_ratio.mean;
  }
  for (const auto& c : sim.soil_bin_cases) {
    if (c.key != t.key) continue;
    if (t.quantity == "window_mean_force_N") return c.force_mean_N;
    if (t.quantity == "window_std_force_N") return c.force_std_N;
    if (t.quantity == "window_mean_deformation_mm") return c.deformation_mean_mm;
    if (t.quantity == "window_std_deformation_mm") return c.deformation_std_mm;
  }
  return std::nullopt;
}

}  // namespace

std::vector<Target> targets(const analysis::EvaluationResult& measured, const ObjectiveSettings& settings) {
  std::vector<Target> out;
  for (const auto& c : measured.calibration_cases) addCalibrationTargets(c, measured, settings, out);
  for (const auto& c : measured.soil_bin_cases) addSoilTargets(c, measured, settings, out);
  return out;
}

analysis::EvaluationResult evaluateEach(const std::vector<analysis::Recording>& runs, const ObjectiveSettings& settings) {
  analysis::EvaluationResult all;
  for (const auto& run : runs) {
    analysis::EvaluationResult one;
    try {
      one = analysis::evaluate({run}, settings.analysis);
    } catch (const analysis::InputError&) {
      continue;  // scored by residuals() as a missing value
    }
    for (auto& r : one.soil_bin_runs) all.soil_bin_runs.push_back(std::move(r));
    for (auto& c : one.soil_bin_cases) all.soil_bin_cases.push_back(std::move(c));
    for (auto& r : one.calibration_runs) all.calibration_runs.push_back(std::move(r));
    for (auto& c : one.calibration_cases) all.calibration_cases.push_back(std::move(c));
  }
  return all;
}

std::vector<Residual> residuals(const std::vector<Target>& targets, const analysis::EvaluationResult& simulated) {
  std::vector<Residual> out;
  for (const Target& t : targets) {
    const double sim = simulatedValue(simulated, t).value_or(0.0);
    out.push_back({t.key, t.quantity, t.measured, sim, t.sigma, (sim - t.measured) / t.sigma});
  }
  return out;
}

double chi2(const std::vector<Residual>& residuals) {
  double sum = 0;
  for (const auto& r : residuals) sum += r.normalized * r.normalized;
  return sum;
}

nlohmann::json toJson(const Residual& r) {
  return {{"case", r.key.label()}, {"quantity", r.quantity}, {"measured", r.measured}, {"simulated", r.simulated},
          {"sigma", r.sigma},      {"normalized", r.normalized}};
}

}  // namespace demfem::campaign
