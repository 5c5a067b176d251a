// The diagnosis procedure (diagnose.hpp): baseline, signatures, one calibration per fold and cause,
// ranking and verdict.
#include "demfem/campaign/diagnose.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

namespace demfem::campaign {
namespace {

// The residuals of the cases whose baseline ran: a case the study as given cannot simulate (a DEM
// blow-up) says nothing about a discrepancy, and scoring its missing quantities as 0 would credit
// any extension whose runs happen not to fail.
std::vector<Residual> comparable(const std::vector<Residual>& residuals, const std::vector<analysis::CaseKey>& failed) {
  std::vector<Residual> out;
  for (const Residual& r : residuals)
    if (std::find(failed.begin(), failed.end(), r.key) == failed.end()) out.push_back(r);
  return out;
}


using Clock = std::chrono::steady_clock;
using nlohmann::ordered_json;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::vector<analysis::Recording> ofKind(const std::vector<analysis::Recording>& recordings, analysis::CaseKind kind) {
  std::vector<analysis::Recording> out;
  for (const auto& r : recordings)
    if (r.key.kind == kind) out.push_back(r);
  return out;
}

std::vector<analysis::CaseKey> casesOf(const std::vector<analysis::Recording>& recordings) {
  std::set<analysis::CaseKey> keys;
  for (const auto& r : recordings) keys.insert(r.key);
  return {keys.begin(), keys.end()};
}

std::vector<double> depthsOf(const std::vector<analysis::Recording>& recordings) {
  std::set<double> depths;
  for (const auto& r : recordings)
    if (r.key.kind == analysis::CaseKind::SoilBin) depths.insert(r.key.depth_mm);
  return {depths.begin(), depths.end()};
}

std::vector<const Cause*> candidates(const std::vector<analysis::Recording>& recordings, const DiagnosisSettings& settings) {
  std::set<analysis::CaseKind> kinds;
  for (const auto& r : recordings) kinds.insert(r.key.kind);
  std::vector<const Cause*> out;
  if (!settings.causes.empty()) {
    for (const std::string& id : settings.causes) {
      const Cause& c = findCause(id);
      if (!kinds.count(c.domain)) throw ArgumentError("--cause " + id + ": the recordings have no case of the kind this cause explains");
      out.push_back(&c);
    }
    return out;
  }
  for (const Cause& c : causeCatalogue())
    if (kinds.count(c.domain)) out.push_back(&c);
  if (out.empty()) throw ArgumentError("no cause of the catalogue explains these recordings");
  return out;
}

struct FoldOutcome {
  std::vector<std::string> unidentified;         // per fold that could not identify the extension
  std::vector<analysis::CaseKey> held_out_cases;  // the folds that identified every parameter
  std::vector<Residual> held_out;
  int model_runs = 0;
};

// Leave one case out: fit on the others, predict the one. A fold whose fit leaves a parameter
// unidentified predicts nothing (a layer only the held-out depth reaches) and is listed.
FoldOutcome crossValidate(const Extension& e, const std::string& id, const std::string& origin,
                          const std::vector<analysis::Recording>& recordings, Model& model, const DiagnosisSettings& settings) {
  FoldOutcome out;
  const auto cases = casesOf(recordings);
  for (std::size_t f = 0; f < cases.size(); ++f) {
    if (settings.on_stage) settings.on_stage("fitting " + id + ", fold " + std::to_string(f + 1) + "/" + std::to_string(cases.size()));
    CalibrationProblem problem{e.study, origin, {}, e.parameters};
    std::vector<analysis::Recording> test;
    for (const auto& r : recordings) (r.key == cases[f] ? test : problem.recordings).push_back(r);
    const CalibrationResult fit = calibrate(problem, model, settings.calibration);
    out.model_runs += fit.model_runs;
    const auto unidentified = std::find_if(fit.parameters.begin(), fit.parameters.end(), [](const FittedParameter& p) { return !p.identified; });
    if (unidentified != fit.parameters.end()) {
      out.unidentified.push_back(unidentified->spec.label() + " without the case " + cases[f].title());
      continue;
    }
    const auto residuals = predict(fit.calibrated_study, origin, test, model, settings.calibration);
    out.held_out.insert(out.held_out.end(), residuals.begin(), residuals.end());
    out.held_out_cases.push_back(cases[f]);
  }
  return out;
}

// The model's seed scatter of every soil-bin quantity of `recordings` (diagnose.hpp, step 5): the
// study's runs at `seeds` deposition seeds (the first is the baseline's run, from the run cache),
// per case and quantity the sample standard deviation of the seeds that ran.
std::vector<SeedScatter> seedScatter(const ordered_json& study, const std::string& origin, const std::vector<analysis::Recording>& recordings,
                                     Model& model, const CalibrationOptions& whole_stroke, int seeds) {
  const std::vector<analysis::Recording> soil = ofKind(recordings, analysis::CaseKind::SoilBin);
  if (soil.empty() || seeds < 2) return {};
  CalibrationOptions options = whole_stroke;
  options.model_seeds = seeds;
  std::vector<analysis::Recording> runs;
  predict(study, origin, soil, model, options, &runs);
  std::map<std::pair<analysis::CaseKey, std::string>, std::vector<double>> values;
  for (int seed = 1; seed <= seeds; ++seed) {
    std::vector<analysis::Recording> one;
    for (const auto& r : runs)
      if (r.repeat == seed) one.push_back(r);
    for (const Quantity& q : quantities(one, options.objective, true)) values[{q.key, q.name}].push_back(q.value);
  }
  std::vector<SeedScatter> out;
  for (const auto& [k, v] : values) {
    if (v.size() < 2) continue;
    double mean = 0, ss = 0;
    for (double x : v) mean += x / static_cast<double>(v.size());
    for (double x : v) ss += (x - mean) * (x - mean);
    out.push_back({k.first, k.second, std::sqrt(ss / static_cast<double>(v.size() - 1)), static_cast<int>(v.size())});
  }
  return out;
}

const SeedScatter* scatterOf(const std::vector<SeedScatter>& scatter, const Residual& r) {
  const auto it = std::find_if(scatter.begin(), scatter.end(), [&](const SeedScatter& s) { return s.key == r.key && s.quantity == r.quantity; });
  return it == scatter.end() ? nullptr : &*it;
}

// A residual's sigma widened by the model's seed scatter of a mean over `model_seeds` runs,
// sqrt(sigma^2 + s_model^2 / M) (diagnose.hpp, step 5): the scatter of a correct model's residual.
double widenedSigma(const Residual& r, const std::vector<SeedScatter>& scatter, int model_seeds) {
  const SeedScatter* s = scatterOf(scatter, r);
  return std::sqrt(r.sigma * r.sigma + (s ? s->sd * s->sd / std::max(1, model_seeds) : 0.0));
}

double chi2WithScatter(const std::vector<Residual>& residuals, const std::vector<SeedScatter>& scatter, int model_seeds) {
  double sum = 0;
  for (const Residual& r : residuals) sum += std::pow((r.simulated - r.measured) / widenedSigma(r, scatter, model_seeds), 2);
  return sum;
}

// The error a correct model shows from the scatter alone (diagnose.hpp, step 4): RMS over the
// residuals of 100 widenedSigma / |measured|, percent.
double noiseErrorPercent(const std::vector<Residual>& residuals, const std::vector<SeedScatter>& scatter, int model_seeds) {
  double sum = 0;
  int n = 0;
  for (const Residual& r : residuals) {
    if (r.measured == 0) continue;
    sum += std::pow(100 * widenedSigma(r, scatter, model_seeds) / r.measured, 2);
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

// Whether `cause` is judged on the quantity of `r` (Cause::judged_on).
bool judges(const Cause& cause, const Residual& r) {
  return cause.judged_on.empty() || std::find(cause.judged_on.begin(), cause.judged_on.end(), r.quantity) != cause.judged_on.end();
}

std::string joined(const std::vector<std::string>& parts) {
  std::string s;
  for (const auto& p : parts) s += (s.empty() ? "" : "; ") + p;
  return s;
}

CauseResult assess(const Cause& cause, const Diagnosis& base, const ordered_json& study, const std::string& origin,
                   const std::vector<analysis::Recording>& recordings, Model& model, const DiagnosisSettings& settings) {
  const auto start = Clock::now();
  CauseResult r;
  r.id = cause.id;
  r.description = cause.description;
  r.expected_signature = cause.expected_signature;
  r.judged_on = cause.judged_on;
  r.match = cause.match(base.signatures, settings.tolerance);
  if (!r.match.plausible) return r;
  const std::vector<analysis::Recording> own = ofKind(recordings, cause.domain);
  const Extension e = cause.extend(study, depthsOf(own));
  if (e.parameters.empty()) throw ArgumentError("cause '" + cause.id + "': the study offers nothing to fit for it");
  r.fitted = true;
  DiagnosisSettings judged = settings;  // the fits see the quantities of the cause's signature only
  judged.calibration.objective.only_quantities = cause.judged_on;
  const auto cases = casesOf(own);
  FoldOutcome folds;
  if (cases.size() >= 2) folds = crossValidate(e, cause.id, origin, own, model, judged);
  if (settings.on_stage) settings.on_stage("fitting " + cause.id + " on all cases");
  const CalibrationResult all = calibrate({e.study, origin, own, e.parameters}, model, judged.calibration);
  r.parameters = all.parameters;
  r.minima = static_cast<int>(all.minima.size());
  r.extended_study = all.calibrated_study;
  r.residuals = all.residuals;
  r.runs = all.calibrated_runs;
  r.chi2 = all.chi2;
  r.model_runs = folds.model_runs + all.model_runs;
  r.held_out_folds = static_cast<int>(folds.held_out_cases.size());
  r.held_out = r.held_out_folds > 0;
  const std::string folds_used = std::to_string(folds.held_out_cases.size()) + " of " + std::to_string(cases.size()) + " folds";
  r.split = !r.held_out && cases.size() < 2 ? "one case only: ranked on all cases (in-sample)"
            : !r.held_out ? "no split can identify the extension (" + joined(folds.unidentified) + "): ranked on all cases (in-sample)"
            : folds.unidentified.empty()
                ? "leave one case out (" + std::to_string(cases.size()) + " folds)"
                : "leave one case out, " + folds_used + " (a split cannot identify " + joined(folds.unidentified) + ")";
  std::vector<Residual> before, before_all;
  for (const Residual& b : comparable(base.baseline_residuals, base.failed_baseline_cases)) {
    if (b.key.kind != cause.domain || !judges(cause, b)) continue;
    before_all.push_back(b);
    if (!r.held_out || std::find(folds.held_out_cases.begin(), folds.held_out_cases.end(), b.key) != folds.held_out_cases.end())
      before.push_back(b);
  }
  r.error_before_percent = errorPercent(before);
  const std::vector<Residual> after = comparable(r.held_out ? folds.held_out : all.residuals, base.failed_baseline_cases);
  r.error_after_percent = errorPercent(after);
  const int m = settings.calibration.model_seeds;
  r.noise_error_percent = noiseErrorPercent(before, base.seed_scatter, m);
  // An error below the noise's is not resolved: what an extension cuts beneath it is the packing of
  // the seeds it ran, not the cause.
  const double resolved_after = std::max(r.error_after_percent, r.noise_error_percent);
  r.gain_percent = r.error_before_percent > 0 ? 100 * (r.error_before_percent - resolved_after) / r.error_before_percent : 0.0;
  const std::vector<Residual> fitted_all = comparable(all.residuals, base.failed_baseline_cases);
  const double n = static_cast<double>(fitted_all.size());
  r.bic = chi2WithScatter(fitted_all, base.seed_scatter, m) + static_cast<double>(e.parameters.size()) * std::log(n);
  r.delta_bic = r.bic - chi2WithScatter(before_all, base.seed_scatter, m);
  r.wall_time_s = secondsSince(start);
  return r;
}

// The quantities of `ran` that no cause of `causes` is judged on, each with the baseline's error.
std::vector<UnjudgedQuantity> unjudgedQuantities(const std::vector<Residual>& ran, const std::vector<const Cause*>& causes) {
  std::vector<UnjudgedQuantity> out;
  for (const std::string& name : quantityNames()) {
    std::vector<Residual> of;
    for (const Residual& r : ran)
      if (r.quantity == name) of.push_back(r);
    if (of.empty()) continue;
    const auto judgesIt = [&](const Cause* c) { return c->domain == of.front().key.kind && judges(*c, of.front()); };
    if (std::none_of(causes.begin(), causes.end(), judgesIt)) out.push_back({name, errorPercent(of)});
  }
  return out;
}

void rank(std::vector<CauseResult>& ranking) {
  std::stable_sort(ranking.begin(), ranking.end(), [](const CauseResult& a, const CauseResult& b) {
    if (a.fitted != b.fitted) return a.fitted;
    if (!a.fitted) return false;
    if (a.error_after_percent != b.error_after_percent) return a.error_after_percent < b.error_after_percent;
    return a.delta_bic < b.delta_bic;
  });
}

std::string number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", v);
  return buffer;
}

void decide(Diagnosis& d, const ordered_json& study, const DiagnosisSettings& settings) {
  d.extended_study = study;
  if (d.baseline_error_percent < settings.min_error_percent) {
    d.reason = "the baseline error on all cases, " + number(d.baseline_error_percent) + " %, is below the threshold of " +
               number(settings.min_error_percent) + " %";
    return;
  }
  if (d.ranking.empty() || !d.ranking.front().fitted) {
    d.reason = "no cause's signature is present in the comparison";
    return;
  }
  const CauseResult& best = d.ranking.front();
  if (best.gain_percent < settings.min_gain_percent) {
    d.reason = "the best extension (" + best.id + ") cuts the error by " + number(best.gain_percent) + " %, less than the " +
               number(settings.min_gain_percent) + " % required";
    return;
  }
  if (best.held_out_folds < settings.min_held_out_folds) {
    d.reason = "the best extension (" + best.id + ") " +
               (best.held_out ? "predicts " + std::to_string(best.held_out_folds) + " held-out case(s)" : std::string("is fitted in-sample only")) +
               ", fewer than the " + std::to_string(settings.min_held_out_folds) + " held-out predictions required (" + best.split + ")";
    return;
  }
  if (best.delta_bic > -settings.min_delta_bic) {
    d.reason = "the best extension (" + best.id + ") changes BIC by " + number(best.delta_bic) + ", not below -" +
               number(settings.min_delta_bic);
    return;
  }
  d.cause = best.id;
  d.gain_percent = best.gain_percent;
  d.extended_study = best.extended_study;
  d.reason = best.id + " cuts the " + std::string(best.held_out ? "held-out" : "in-sample") + " error from " +
             number(best.error_before_percent) + " % to " + number(best.error_after_percent) + " % (gain " + number(best.gain_percent) +
             " %, delta BIC " + number(best.delta_bic) + ")";
}

}  // namespace

double errorPercent(const std::vector<Residual>& residuals) {
  double sum = 0;
  int n = 0;
  for (const Residual& r : residuals) {
    if (r.measured == 0) continue;
    const double e = 100 * (r.simulated - r.measured) / r.measured;
    sum += e * e;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

Diagnosis diagnose(const ordered_json& study, const std::string& origin, const std::vector<analysis::Recording>& recordings, Model& model,
                   const DiagnosisSettings& given) {
  const auto start = Clock::now();
  // The model's seed scatter is measured here (step 5) and widens the comparison; the fits keep
  // the measured sigma so that it is not counted twice.
  DiagnosisSettings settings = given;
  settings.calibration.model_scatters_like_repeats = false;
  Diagnosis d;
  d.measured = recordings;
  const std::vector<const Cause*> causes = candidates(recordings, settings);
  if (settings.on_stage) settings.on_stage("baseline prediction");
  // The baseline runs the whole stroke: the end-of-stroke signature compares like with like.
  CalibrationOptions whole_stroke = settings.calibration;
  whole_stroke.stroke_ends_with_window = false;
  d.baseline_residuals = predict(study, origin, recordings, model, whole_stroke, &d.baseline_runs);
  for (const Residual& r : d.baseline_residuals)
    if (r.missing && std::find(d.failed_baseline_cases.begin(), d.failed_baseline_cases.end(), r.key) == d.failed_baseline_cases.end())
      d.failed_baseline_cases.push_back(r.key);
  const std::vector<Residual> ran = comparable(d.baseline_residuals, d.failed_baseline_cases);
  if (ran.empty()) throw std::runtime_error("diagnose: the study as given fails (DEM blow-up) on every case; nothing to compare");
  d.baseline_error_percent = errorPercent(ran);
  d.baseline_chi2 = chi2(ran);
  d.residual_count = static_cast<int>(d.baseline_residuals.size());
  if (settings.on_stage && settings.scatter_seeds > 1) settings.on_stage("the model's seed scatter");
  d.seed_scatter = seedScatter(study, origin, recordings, model, whole_stroke, settings.scatter_seeds);
  d.noise_error_percent = noiseErrorPercent(ran, d.seed_scatter, settings.calibration.model_seeds);
  const analysis::ComparisonResult comparison = analysis::compare(recordings, d.baseline_runs, settings.calibration.objective.analysis);
  d.signatures = analysis::signaturesOf(comparison, settings.signatures);
  d.unjudged = unjudgedQuantities(ran, causes);
  for (const Cause* c : causes) d.ranking.push_back(assess(*c, d, study, origin, recordings, model, settings));
  rank(d.ranking);
  decide(d, study, settings);
  d.wall_time_s = secondsSince(start);
  return d;
}

}  // namespace demfem::campaign
