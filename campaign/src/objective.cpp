#include "demfem/campaign/objective.hpp"

#include "demfem/analysis/step_fit.hpp"
#include "demfem/campaign/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace demfem::campaign {
namespace {

// One repeat's value of a quantity and its own uncertainty.
struct Estimate {
  double value = 0;
  double error = 0;  // weight fits: standard error; windows: the sample-based error of this repeat
};

using CaseEstimates = std::map<std::string, std::vector<Estimate>>;

// The repeats' mean and their sample variance (0 for one repeat).
std::pair<double, double> meanAndVariance(const std::vector<Estimate>& repeats) {
  const auto R = static_cast<double>(repeats.size());
  double mean = 0, variance = 0;
  for (const auto& e : repeats) mean += e.value / R;
  if (repeats.size() > 1)
    for (const auto& e : repeats) variance += (e.value - mean) * (e.value - mean) / (R - 1);
  return {mean, variance};
}

// Per quantity name, the between-repeat variance relative to the mean squared, pooled over the
// cases with two or more repeats (weighted by their degrees of freedom; header comment).
std::map<std::string, double> pooledRelativeVariance(const std::map<analysis::CaseKey, std::map<std::string, std::vector<Estimate>>>& cases) {
  std::map<std::string, std::pair<double, double>> sums;  // name -> (sum dof x relative variance, sum dof)
  for (const auto& [key, estimates] : cases)
    for (const auto& [name, repeats] : estimates) {
      const auto [mean, variance] = meanAndVariance(repeats);
      if (repeats.size() < 2 || mean == 0) continue;
      const double dof = static_cast<double>(repeats.size() - 1);
      sums[name].first += dof * variance / (mean * mean);
      sums[name].second += dof;
    }
  std::map<std::string, double> out;
  for (const auto& [name, sum] : sums) out[name] = sum.first / sum.second;
  return out;
}

// Mean over repeats and the scatter of that mean (header comment).
Quantity pool(const analysis::CaseKey& key, const std::string& name, const std::vector<Estimate>& repeats, double pooled_relative_variance,
              const ObjectiveSettings& settings) {
  const auto R = static_cast<double>(repeats.size());
  const auto [mean, own_between] = meanAndVariance(repeats);
  double own = 0;
  for (const auto& e : repeats) own += e.error * e.error / R;
  const double between = repeats.size() > 1 ? std::max(own_between, pooled_relative_variance * mean * mean) : 0.0;
  const auto relative = settings.model_form_relative.find(name);
  const double form = relative == settings.model_form_relative.end() ? 0.0 : relative->second * mean;
  const double sigma = std::sqrt(std::max(between, own) / R + form * form);
  return {key, name, mean, std::max(sigma, settings.relative_floor * std::abs(mean)), std::sqrt(between)};
}

void addWeightRun(const analysis::Recording& rec, CaseEstimates& out) {
  const WeightSignals s = weightSignals(rec);
  const std::string file = rec.csv_path.string();
  const auto f = analysis::fitStepResponse(s.time_s, s.force_N, file + ": force");
  const auto d = analysis::fitStepResponse(s.time_s, s.deformation_mm, file + ": deformation");
  out["step_force_N"].push_back({f.steady - f.initial, f.steady_error});
  out["step_deformation_mm"].push_back({d.steady - d.initial, d.steady_error});
  out["frequency_Hz"].push_back({d.frequency_Hz, d.frequency_error_Hz});
  out["damping_ratio"].push_back({d.damping_ratio, d.damping_ratio_error});
}

void addSoilRun(const analysis::Recording& rec, const ObjectiveSettings& s, CaseEstimates& out) {
  const analysis::EvaluatedRun run = analysis::evaluateSoilBinRun(rec, s.analysis.evaluation);
  const auto add = [&](const std::string& name, const analysis::SignalStatistics& w) {
    const double n = static_cast<double>(std::max<std::size_t>(w.samples, 2));
    out["window_mean_" + name].push_back({w.mean, w.std_dev / std::sqrt(n)});
    out["window_std_" + name].push_back({w.std_dev, w.std_dev / std::sqrt(2 * (n - 1))});
  };
  add("force_N", run.window.force_N);
  if (s.soil_deformation) add("deformation_mm", run.window.deformation_mm);
}

// The names quantities() keeps: settings.only_quantities, checked against quantityNames().
std::vector<std::string> keptNames(const ObjectiveSettings& settings) {
  if (settings.only_quantities.empty()) return quantityNames();
  std::vector<std::string> kept;
  for (const std::string& name : quantityNames())
    if (std::find(settings.only_quantities.begin(), settings.only_quantities.end(), name) != settings.only_quantities.end()) kept.push_back(name);
  for (const std::string& name : settings.only_quantities)
    if (std::find(kept.begin(), kept.end(), name) == kept.end()) {
      std::string names;
      for (const std::string& n : quantityNames()) names += (names.empty() ? "" : ", ") + n;
      throw ArgumentError("objective: '" + name + "' is not a quantity (quantities: " + names + ")");
    }
  return kept;
}

}  // namespace

// The order quantities are listed in (stable across measured and simulated sides).
const std::vector<std::string>& quantityNames() {
  static const std::vector<std::string> order = {"step_force_N",         "step_deformation_mm",        "frequency_Hz",
                                                 "damping_ratio",        "window_mean_force_N",        "window_std_force_N",
                                                 "window_mean_deformation_mm", "window_std_deformation_mm"};
  return order;
}

WeightSignals weightSignals(const analysis::Recording& rec) {
  const bool raw = rec.format == analysis::RecordingFormat::Raw;
  WeightSignals s;
  s.time_s = rec.time_s;
  for (std::size_t i = 0; i < rec.size(); ++i) {
    s.force_N.push_back(rec.force[i] * (raw ? rec.force_factor_N_per_unit : 1.0));
    s.deformation_mm.push_back(rec.deformation[i] * (raw ? rec.deformation_factor_mm_per_unit : 1.0));
  }
  return s;
}

std::vector<Quantity> quantities(const std::vector<analysis::Recording>& recordings, const ObjectiveSettings& settings, bool tolerate_failures) {
  const std::vector<std::string> kept = keptNames(settings);
  std::map<analysis::CaseKey, CaseEstimates> cases;
  for (const auto& rec : recordings) {
    CaseEstimates one;
    try {
      switch (rec.key.kind) {
        case analysis::CaseKind::CalibrationWeight:
          addWeightRun(rec, one);
          break;
        case analysis::CaseKind::SoilBin:
          addSoilRun(rec, settings, one);
          break;
      }
    } catch (const analysis::InputError&) {
      if (!tolerate_failures) throw;
      continue;
    }
    for (auto& [name, estimates] : one) cases[rec.key][name].push_back(estimates.front());
  }
  const std::map<std::string, double> pooled = pooledRelativeVariance(cases);
  std::vector<Quantity> out;
  for (const auto& [key, estimates] : cases)
    for (const auto& name : kept)
      if (auto it = estimates.find(name); it != estimates.end())
        out.push_back(pool(key, name, it->second, pooled.count(name) ? pooled.at(name) : 0.0, settings));
  return out;
}

std::vector<Residual> residuals(const std::vector<Quantity>& measured, const std::vector<Quantity>& simulated) {
  std::vector<Residual> out;
  for (const Quantity& m : measured) {
    const auto it = std::find_if(simulated.begin(), simulated.end(), [&](const Quantity& s) { return s.key == m.key && s.name == m.name; });
    const double sim = it == simulated.end() ? 0.0 : it->value;
    out.push_back({m.key, m.name, m.value, sim, m.sigma, (sim - m.value) / m.sigma, it == simulated.end()});
  }
  return out;
}

double chi2(const std::vector<Residual>& residuals) {
  double sum = 0;
  for (const auto& r : residuals) sum += r.normalized * r.normalized;
  return sum;
}

}  // namespace demfem::campaign
