#include "demfem/analysis/signatures.hpp"

#include <algorithm>
#include <cmath>

namespace demfem::analysis {
namespace {

// Standard error of a case's mean of one fitted figure (step_fit.hpp) over its repeats: the larger
// of the propagated fit errors and the spread between repeats over sqrt(repeats).
double caseError(const std::vector<CalibrationRun>& runs, const CaseKey& key, bool force, double StepResponseFit::*value,
                 double StepResponseFit::*error) {
  std::vector<double> values;
  double variance = 0;
  for (const CalibrationRun& run : runs) {
    if (run.key != key) continue;
    const StepResponseFit& fit = (force ? run.force : run.deformation).fit;
    values.push_back(fit.*value);
    variance += (fit.*error) * (fit.*error);
  }
  if (values.empty()) return 0.0;
  const double n = static_cast<double>(values.size());
  const double propagated = std::sqrt(variance) / n;
  if (values.size() < 2) return propagated;
  const SignalStatistics spread = meanAndStdDev(values);
  return std::max(propagated, spread.std_dev / std::sqrt(n));
}

Estimate ratio(double measured, double measured_error, double simulated) {
  return {measured / simulated, measured_error / std::abs(simulated)};
}

WeightDropSignature weightSignature(const CalibrationComparison& c, const ComparisonResult& all) {
  const auto& runs = all.measured.calibration_runs;
  const ResponseSummary& mf = c.measured.force;
  const ResponseSummary& sf = c.simulated.force;
  const ResponseSummary& md = c.measured.deformation;
  const ResponseSummary& sd = c.simulated.deformation;
  WeightDropSignature s;
  s.key = c.key;
  s.force_ratio = ratio(mf.steady.mean, caseError(runs, c.key, true, &StepResponseFit::steady, &StepResponseFit::steady_error), sf.steady.mean);
  s.deformation_ratio =
      ratio(md.steady.mean, caseError(runs, c.key, false, &StepResponseFit::steady, &StepResponseFit::steady_error), sd.steady.mean);
  s.force_per_weight_measured_N_per_kg = mf.steady.mean / c.key.mass_kg;
  s.force_per_weight_simulated_N_per_kg = sf.steady.mean / c.key.mass_kg;
  s.frequency_ratio = ratio(mf.frequency_Hz.mean,
                            caseError(runs, c.key, true, &StepResponseFit::frequency_Hz, &StepResponseFit::frequency_error_Hz),
                            sf.frequency_Hz.mean);
  s.damping_difference = {mf.damping_ratio.mean - sf.damping_ratio.mean,
                          caseError(runs, c.key, true, &StepResponseFit::damping_ratio, &StepResponseFit::damping_ratio_error)};
  return s;
}

WeightDropRelations relationsOf(const std::vector<WeightDropSignature>& weights) {
  WeightDropRelations r;
  if (weights.size() < 2) return r;
  const WeightDropSignature& light = weights.front();
  const WeightDropSignature& heavy = weights.back();
  r.defined = true;
  r.force_ratio_change = heavy.force_ratio.value - light.force_ratio.value;
  r.deformation_ratio_change = heavy.deformation_ratio.value - light.deformation_ratio.value;
  r.damping_difference_change = heavy.damping_difference.value - light.damping_difference.value;
  for (const WeightDropSignature& w : weights)
    r.stiffness_consistency += w.frequency_ratio.value * w.frequency_ratio.value * w.deformation_ratio.value;
  r.stiffness_consistency /= static_cast<double>(weights.size());
  return r;
}

// Mean force over the last `fraction` of the curve's displacement range, over the window mean.
double endRise(const PooledCase& c, double fraction) {
  const DisplacementCurve& curve = c.mean_curve;
  if (curve.size() == 0 || !(c.force_mean_N != 0)) return 0.0;
  const double x_end = curve.displacement_mm.back();
  const double x_begin = x_end - fraction * (x_end - curve.displacement_mm.front());
  double sum = 0;
  int n = 0;
  for (std::size_t i = 0; i < curve.size(); ++i)
    if (curve.displacement_mm[i] >= x_begin) sum += curve.force_N[i], ++n;
  return n > 0 ? sum / n / c.force_mean_N : 0.0;
}

SoilBinSignature soilSignature(const SoilBinComparison& c, const SignatureSettings& settings) {
  SoilBinSignature s;
  s.key = c.key;
  s.force_bias_percent = c.force_difference_percent;
  s.deformation_bias_percent = c.deformation_difference_percent;
  s.end_rise_difference = endRise(c.simulated, settings.end_fraction) - endRise(c.measured, settings.end_fraction);
  s.fluctuation_ratio = c.simulated.force_std_N / c.measured.force_std_N;
  s.spectral_slope_measured = c.force_spectrum.measured_fit.b;
  s.spectral_slope_simulated = c.force_spectrum.simulated_fit.b;
  return s;
}

// Least-squares slope of y against x; nullopt for fewer than two distinct x.
std::optional<double> slope(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() < 2) return std::nullopt;
  const double n = static_cast<double>(x.size());
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < x.size(); ++i) mx += x[i] / n, my += y[i] / n;
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sxy += (x[i] - mx) * (y[i] - my), sxx += (x[i] - mx) * (x[i] - mx);
  if (!(sxx > 0)) return std::nullopt;
  return sxy / sxx;
}

// Mean force of one run over the displacement interval of `phase` while the tool moves: from the
// last sample at the curve's smallest displacement to the first at its largest (a calibrated curve,
// taken as it is, may hold the rest before the stroke and after it). nullopt without samples.
std::optional<double> phaseForce(const DisplacementCurve& curve, StrokePhase phase, const EvaluationSettings& settings) {
  if (curve.size() == 0) return std::nullopt;
  const auto& x_all = curve.displacement_mm;
  const auto last = static_cast<std::size_t>(std::max_element(x_all.begin(), x_all.end()) - x_all.begin());
  std::size_t first = 0;
  for (std::size_t i = 0; i <= last; ++i)
    if (x_all[i] <= x_all[first]) first = i;
  double sum = 0;
  int n = 0;
  for (std::size_t i = first; i <= last; ++i) {
    const double x = curve.displacement_mm[i];
    bool inside = false;
    switch (phase) {
      case StrokePhase::Insertion:
        inside = x < settings.window_begin_mm;
        break;
      case StrokePhase::Window:
        inside = x >= settings.window_begin_mm && x <= settings.window_end_mm;
        break;
      case StrokePhase::EndOfStroke:
        inside = x > settings.window_end_mm;
        break;
    }
    if (inside) sum += curve.force_N[i], ++n;
  }
  if (n == 0) return std::nullopt;
  return sum / n;
}

PhaseMean phaseMean(const std::vector<EvaluatedRun>& runs, const CaseKey& key, StrokePhase phase, const EvaluationSettings& settings) {
  std::vector<double> means;
  for (const EvaluatedRun& r : runs)
    if (r.key == key)
      if (const auto m = phaseForce(r.curve, phase, settings)) means.push_back(*m);
  PhaseMean out;
  out.runs = static_cast<int>(means.size());
  if (means.empty()) return out;
  const SignalStatistics stats = meanAndStdDev(means);
  out.mean_N = stats.mean;
  if (means.size() >= 2) out.std_error_N = stats.std_dev / std::sqrt(static_cast<double>(means.size()));
  return out;
}

using namespace report;

// "value +- standard error" of the columns NAME and NAME_std_error.
MarkdownCell estimateCell(const std::string& name) {
  return md::concat({md::number(name), md::literal(" +- "), md::number(name + "_std_error", 2)});
}

// The columns NAME and NAME_std_error of an estimate.
void addEstimate(std::vector<Column<WeightDropSignature>>& columns, const std::string& name, Estimate WeightDropSignature::*estimate) {
  columns.push_back({name, [estimate](const WeightDropSignature& w) -> CellValue { return (w.*estimate).value; }});
  columns.push_back({name + "_std_error", [estimate](const WeightDropSignature& w) -> CellValue { return (w.*estimate).std_error; }});
}

}  // namespace

std::string phaseName(StrokePhase phase) {
  switch (phase) {
    case StrokePhase::Insertion:
      return "insertion";
    case StrokePhase::Window:
      return "window";
    case StrokePhase::EndOfStroke:
      return "end of stroke";
  }
  return "?";
}

std::vector<StrokePhaseForce> strokePhaseForces(const ComparisonResult& comparison, const EvaluationSettings& settings) {
  std::vector<StrokePhaseForce> out;
  for (const SoilBinComparison& c : comparison.soil_bin)
    for (const StrokePhase phase : {StrokePhase::Insertion, StrokePhase::Window, StrokePhase::EndOfStroke}) {
      StrokePhaseForce f{c.key, phase, phaseMean(comparison.measured.soil_bin_runs, c.key, phase, settings),
                         phaseMean(comparison.simulated.soil_bin_runs, c.key, phase, settings)};
      if (f.measured.runs > 0 && f.simulated.runs > 0) out.push_back(f);
    }
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.key.depth_mm < b.key.depth_mm; });
  return out;
}

Signatures signaturesOf(const ComparisonResult& comparison, const SignatureSettings& settings) {
  Signatures s;
  for (const CalibrationComparison& c : comparison.calibration) s.weight_drops.push_back(weightSignature(c, comparison));
  std::sort(s.weight_drops.begin(), s.weight_drops.end(),
            [](const auto& a, const auto& b) { return a.key.mass_kg < b.key.mass_kg; });
  s.weight_relations = relationsOf(s.weight_drops);
  for (const SoilBinComparison& c : comparison.soil_bin) s.soil_bins.push_back(soilSignature(c, settings));
  std::sort(s.soil_bins.begin(), s.soil_bins.end(), [](const auto& a, const auto& b) { return a.key.depth_mm < b.key.depth_mm; });
  std::vector<double> depth, bias;
  for (const SoilBinSignature& b : s.soil_bins) depth.push_back(b.key.depth_mm), bias.push_back(b.force_bias_percent);
  s.force_bias_per_depth_percent_per_mm = slope(depth, bias);
  return s;
}

const Section<WeightDropSignature>& weightDropSignatureSection() {
  using R = WeightDropSignature;
  static const Section<R> section = [] {
    std::vector<Column<R>> c{{"case", [](const R& w) -> CellValue { return w.key.label(); }},
                             {"mass_kg", [](const R& w) -> CellValue { return w.key.mass_kg; }}};
    addEstimate(c, "force_ratio", &R::force_ratio);
    addEstimate(c, "deformation_ratio", &R::deformation_ratio);
    c.push_back({"force_per_weight_measured_N_per_kg", [](const R& w) -> CellValue { return w.force_per_weight_measured_N_per_kg; }});
    c.push_back({"force_per_weight_simulated_N_per_kg", [](const R& w) -> CellValue { return w.force_per_weight_simulated_N_per_kg; }});
    addEstimate(c, "frequency_ratio", &R::frequency_ratio);
    addEstimate(c, "damping_ratio_difference", &R::damping_difference);
    return Section<R>{std::move(c),
                      [](const R& w) { return shortNum(w.key.mass_kg) + " kg"; },
                      {{"force ratio", estimateCell("force_ratio")},
                       {"deformation ratio", estimateCell("deformation_ratio")},
                       {"force per weight meas / sim (N/kg)", md::concat({md::number("force_per_weight_measured_N_per_kg"), md::literal(" / "),
                                                                          md::number("force_per_weight_simulated_N_per_kg")})},
                       {"frequency ratio", estimateCell("frequency_ratio")},
                       {"damping ratio difference", estimateCell("damping_ratio_difference")}},
                      "weight"};
  }();
  return section;
}

const Section<SoilBinSignature>& soilBinSignatureSection() {
  using R = SoilBinSignature;
  static const Section<R> section{
      {{"case", [](const R& b) -> CellValue { return b.key.label(); }},
       {"depth_mm", [](const R& b) -> CellValue { return b.key.depth_mm; }},
       {"force_bias_percent", [](const R& b) -> CellValue { return b.force_bias_percent; }},
       {"deformation_bias_percent", [](const R& b) -> CellValue { return b.deformation_bias_percent; }},
       {"end_rise_difference", [](const R& b) -> CellValue { return b.end_rise_difference; }},
       {"fluctuation_ratio", [](const R& b) -> CellValue { return b.fluctuation_ratio; }},
       {"spectral_slope_measured", [](const R& b) -> CellValue { return b.spectral_slope_measured; }},
       {"spectral_slope_simulated", [](const R& b) -> CellValue { return b.spectral_slope_simulated; }}},
      [](const R& b) { return shortNum(b.key.depth_mm) + " mm"; },
      {{"force bias (%)", md::number("force_bias_percent")},
       {"deformation bias (%)", md::number("deformation_bias_percent")},
       {"end rise sim - meas", md::number("end_rise_difference")},
       {"fluctuation ratio", md::number("fluctuation_ratio")},
       {"spectral slope meas / sim", md::concat({md::number("spectral_slope_measured"), md::literal(" / "), md::number("spectral_slope_simulated")})}},
      "depth"};
  return section;
}

nlohmann::json toJson(const Signatures& s) {
  nlohmann::json j;
  j["weight_drops"] = weightDropSignatureSection().json(s.weight_drops);
  if (s.weight_relations.defined)
    j["weight_relations"] = {{"force_ratio_change", s.weight_relations.force_ratio_change},
                             {"deformation_ratio_change", s.weight_relations.deformation_ratio_change},
                             {"damping_ratio_difference_change", s.weight_relations.damping_difference_change},
                             {"stiffness_consistency", s.weight_relations.stiffness_consistency}};
  else
    j["weight_relations"] = nullptr;
  j["soil_bins"] = soilBinSignatureSection().json(s.soil_bins);
  j["force_bias_per_depth_percent_per_mm"] =
      s.force_bias_per_depth_percent_per_mm ? nlohmann::json(*s.force_bias_per_depth_percent_per_mm) : nlohmann::json(nullptr);
  return j;
}

}  // namespace demfem::analysis
