#include "demfem/analysis/workflow.hpp"

#include "group_by_case.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

namespace demfem::analysis {
namespace {

CalibrationRun analyseCalibrationRun(const Recording& rec, const AnalysisSettings& settings) {
  CalibrationRun run;
  run.key = rec.key;
  run.repeat = rec.repeat;
  run.source = rec.csv_path;
  run.time_s = rec.time_s;
  const bool raw = rec.format == RecordingFormat::Raw;
  const double force_factor = raw ? rec.force_factor_N_per_unit : 1.0;
  const double deformation_factor = raw ? rec.deformation_factor_mm_per_unit : 1.0;
  for (std::size_t i = 0; i < rec.size(); ++i) {
    run.force_N.push_back(rec.force[i] * force_factor);
    run.deformation_mm.push_back(rec.deformation[i] * deformation_factor);
  }
  const std::string file = rec.csv_path.string();
  run.force = analyseStepResponse(run.time_s, run.force_N, settings.step_response, file + ": column '" + std::string(raw ? "force" : "force_N") + "'");
  run.deformation = analyseStepResponse(run.time_s, run.deformation_mm, settings.step_response,
                                        file + ": column '" + std::string(raw ? "deformation" : "deformation_mm") + "'");
  return run;
}

// Fitted values averaged over the repeats; the spread over all their cycles (Fig. 8).
SignalStatistics fittedWithCycleSpread(const std::vector<double>& fitted, const std::vector<double>& cycles) {
  SignalStatistics s;
  s.mean = meanAndStdDev(fitted).mean;
  s.samples = cycles.size();
  s.std_dev = cycles.size() < 2 ? std::numeric_limits<double>::quiet_NaN() : meanAndStdDev(cycles).std_dev;
  return s;
}

ResponseSummary summarise(const std::vector<const StepResponse*>& responses) {
  std::vector<double> steady, frequencies, damping, cycle_frequencies, cycle_damping;
  for (const StepResponse* r : responses) {
    steady.push_back(r->fit.steady);
    frequencies.push_back(r->fit.frequency_Hz);
    damping.push_back(r->fit.damping_ratio);
    cycle_frequencies.insert(cycle_frequencies.end(), r->cycle_frequencies_Hz.begin(), r->cycle_frequencies_Hz.end());
    cycle_damping.insert(cycle_damping.end(), r->cycle_damping_ratios.begin(), r->cycle_damping_ratios.end());
  }
  return {meanAndStdDev(steady), fittedWithCycleSpread(frequencies, cycle_frequencies), fittedWithCycleSpread(damping, cycle_damping)};
}

// The window segment of a run's curve as a time series of one signal.
Spectrum windowSpectrum(const EvaluatedRun& run, const std::vector<double>& signal, const EvaluationSettings& settings) {
  std::vector<double> t, y;
  for (std::size_t i = 0; i < run.curve.size(); ++i) {
    const double x = run.curve.displacement_mm[i];
    if (x < settings.window_begin_mm || x > settings.window_end_mm) continue;
    if (!t.empty() && run.curve.time_s[i] <= t.back()) continue;
    t.push_back(run.curve.time_s[i]);
    y.push_back(signal[i]);
  }
  return amplitudeSpectrum(t, y);
}

PowerLawFit fitPooled(const std::vector<Spectrum>& spectra, double f_low, double f_high, const std::string& what) {
  std::vector<double> f, a;
  for (const auto& s : spectra) {
    f.insert(f.end(), s.frequency_Hz.begin(), s.frequency_Hz.end());
    a.insert(a.end(), s.amplitude.begin(), s.amplitude.end());
  }
  try {
    return fitPowerLaw(f, a, f_low, f_high);
  } catch (const std::invalid_argument& e) {
    throw InputError(what + ": " + e.what());
  }
}

SpectralComparison compareSpectra(const std::vector<const EvaluatedRun*>& measured, const std::vector<const EvaluatedRun*>& simulated,
                                  bool deformation, const AnalysisSettings& settings, const std::string& what) {
  SpectralComparison result;
  const auto signalOf = [deformation](const EvaluatedRun& r) -> const std::vector<double>& {
    return deformation ? r.curve.deformation_mm : r.curve.force_N;
  };
  for (const auto* r : measured) result.measured.push_back(windowSpectrum(*r, signalOf(*r), settings.evaluation));
  for (const auto* r : simulated) result.simulated.push_back(windowSpectrum(*r, signalOf(*r), settings.evaluation));
  double f_low = settings.fft_low_Hz, f_high = settings.fft_high_Hz;
  for (const auto* side : {&result.measured, &result.simulated})
    for (const auto& s : *side) {
      f_low = std::max(f_low, s.frequency_Hz.front());
      f_high = std::min(f_high, s.frequency_Hz.back());
    }
  if (!(f_high > f_low))
    throw InputError(what + ": the measured and simulated spectra share no frequency band (lowest common bin " + std::to_string(f_low) +
                     " Hz, highest common frequency " + std::to_string(f_high) + " Hz)");
  result.measured_fit = fitPooled(result.measured, f_low, f_high, what + " (measured)");
  result.simulated_fit = fitPooled(result.simulated, f_low, f_high, what + " (simulated)");
  result.amplitude_ratio_at_1Hz = result.simulated_fit.a / result.measured_fit.a;
  result.mean_fitted_ratio = meanFittedRatio(result.simulated_fit, result.measured_fit, f_low, f_high);
  return result;
}

// The cases of both sides paired by key as Comparison{key, measured, simulated}, in the measured
// order; every case on one side only is added to `unmatched` (measured ones first).
template <class Comparison, class Case>
std::vector<Comparison> pairCases(const std::vector<Case>& measured, const std::vector<Case>& simulated, std::vector<std::string>& unmatched) {
  const auto find = [](const std::vector<Case>& cases, const CaseKey& key) {
    return std::find_if(cases.begin(), cases.end(), [&key](const Case& c) { return c.key == key; });
  };
  std::vector<Comparison> pairs;
  for (const Case& m : measured) {
    const auto s = find(simulated, m.key);
    if (s == simulated.end()) unmatched.push_back(m.key.title() + " (measured only)");
    else {
      Comparison c;  // the differences are filled by the caller
      c.key = m.key;
      c.measured = m;
      c.simulated = *s;
      pairs.push_back(std::move(c));
    }
  }
  for (const Case& s : simulated)
    if (find(measured, s.key) == measured.end()) unmatched.push_back(s.key.title() + " (simulated only)");
  return pairs;
}

// Differences of the pooled means (Fig. 15) and spectra (Fig. 17) of one paired soil-bin case.
void compareSoilBinCase(SoilBinComparison& c, const std::vector<const EvaluatedRun*>& measured_runs,
                        const std::vector<const EvaluatedRun*>& simulated_runs, const AnalysisSettings& settings) {
  c.force_difference_percent = percentDifference(c.measured.force_mean_N, c.simulated.force_mean_N);
  c.deformation_difference_percent = percentDifference(c.measured.deformation_mean_mm, c.simulated.deformation_mean_mm);
  const std::string what = "case " + c.key.title();
  c.force_spectrum = compareSpectra(measured_runs, simulated_runs, false, settings, what + ", force spectrum");
  // A rigid tool (a DEM simulation's draught) records no deformation on either side: no spectrum.
  const auto rigid = [](const std::vector<const EvaluatedRun*>& runs) {
    return std::all_of(runs.begin(), runs.end(), [](const EvaluatedRun* r) {
      return std::all_of(r->curve.deformation_mm.begin(), r->curve.deformation_mm.end(), [](double d) { return d == 0.0; });
    });
  };
  if (!rigid(measured_runs) || !rigid(simulated_runs))
    c.deformation_spectrum = compareSpectra(measured_runs, simulated_runs, true, settings, what + ", deformation spectrum");
}

// A measured calibration-weight run correlated with the simulated one after aligning their first
// local maxima (Section 3.1).
SignalCorrelation correlate(const CalibrationRun& run, const CalibrationRun& sim) {
  SignalCorrelation corr;
  corr.measured_repeat = run.repeat;
  const std::string what = run.source.string() + " against " + sim.source.string();
  corr.force = correlateAligned(run.time_s, run.force_N, run.force.first_peak_time_s, sim.time_s, sim.force_N, sim.force.first_peak_time_s,
                                what + " (force)");
  corr.deformation = correlateAligned(run.time_s, run.deformation_mm, run.deformation.first_peak_time_s, sim.time_s, sim.deformation_mm,
                                      sim.deformation.first_peak_time_s, what + " (deformation)");
  return corr;
}

}  // namespace

double percentDifference(double measured, double simulated) {
  if (measured == 0.0) return std::numeric_limits<double>::quiet_NaN();
  return 100.0 * (simulated - measured) / measured;
}

EvaluationResult evaluate(const std::vector<Recording>& recordings, const AnalysisSettings& settings) {
  EvaluationResult result;
  for (const auto& rec : recordings) {
    if (rec.key.kind == CaseKind::SoilBin) result.soil_bin_runs.push_back(evaluateSoilBinRun(rec, settings.evaluation));
    else result.calibration_runs.push_back(analyseCalibrationRun(rec, settings));
  }
  for (const auto& [key, runs] : detail::groupByCase(result.soil_bin_runs)) result.soil_bin_cases.push_back(poolRepeats(runs, settings.evaluation));
  for (const auto& [key, runs] : detail::groupByCase(result.calibration_runs)) {
    CalibrationCase c;
    c.key = key;
    std::vector<const StepResponse*> force, deformation;
    for (const auto* run : runs) {
      c.repeats.push_back(run->repeat);
      force.push_back(&run->force);
      deformation.push_back(&run->deformation);
    }
    c.force = summarise(force);
    c.deformation = summarise(deformation);
    result.calibration_cases.push_back(std::move(c));
  }
  return result;
}

std::optional<std::string> singleToolMatch(const std::vector<Recording>& measured, const std::vector<Recording>& simulated) {
  const auto tools = [](const std::vector<Recording>& recordings) {
    std::set<std::string> names;
    for (const auto& r : recordings) names.insert(r.key.tool);
    return names;
  };
  const std::set<std::string> measured_tools = tools(measured), simulated_tools = tools(simulated);
  if (measured_tools.size() != 1 || simulated_tools.size() != 1 || measured_tools == simulated_tools) return std::nullopt;
  return *measured_tools.begin();
}

ComparisonResult compare(const std::vector<Recording>& measured, const std::vector<Recording>& simulated_as_named,
                         const AnalysisSettings& settings) {
  ComparisonResult result;
  std::vector<Recording> simulated = simulated_as_named;
  if (const auto tool = singleToolMatch(measured, simulated)) {
    result.simulated_tool_matched_as = {simulated.front().key.tool, *tool};
    for (auto& r : simulated) r.key.tool = *tool;
  }
  result.measured = evaluate(measured, settings);
  result.simulated = evaluate(simulated, settings);

  const auto measured_runs = detail::groupByCase(result.measured.soil_bin_runs);
  const auto simulated_runs = detail::groupByCase(result.simulated.soil_bin_runs);
  for (SoilBinComparison& c :
       pairCases<SoilBinComparison>(result.measured.soil_bin_cases, result.simulated.soil_bin_cases, result.unmatched_cases)) {
    compareSoilBinCase(c, measured_runs.at(c.key), simulated_runs.at(c.key), settings);
    result.soil_bin.push_back(std::move(c));
  }
  const auto measured_calibration = detail::groupByCase(result.measured.calibration_runs);
  const auto simulated_calibration = detail::groupByCase(result.simulated.calibration_runs);
  for (CalibrationComparison& c :
       pairCases<CalibrationComparison>(result.measured.calibration_cases, result.simulated.calibration_cases, result.unmatched_cases)) {
    const CalibrationRun& sim = *simulated_calibration.at(c.key).front();
    for (const CalibrationRun* run : measured_calibration.at(c.key)) c.correlations.push_back(correlate(*run, sim));
    result.calibration.push_back(std::move(c));
  }

  if (result.soil_bin.empty() && result.calibration.empty())
    throw InputError("no case appears among both the measured and the simulated recordings (cases are matched by the sidecars' tool and "
                     "depth_mm or mass_kg); unmatched: " +
                     [&] {
                       std::string list;
                       for (const auto& u : result.unmatched_cases) list += (list.empty() ? "" : "; ") + u;
                       return list;
                     }());
  return result;
}

}  // namespace demfem::analysis
