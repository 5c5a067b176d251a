// The diagnosis procedure (diagnose.hpp): baseline, signatures, one calibration per fold and cause,
// ranking and verdict.
#include "demfem/campaign/diagnose.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <set>

namespace demfem::campaign {
namespace {

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
  r.match = cause.match(base.signatures, settings.tolerance);
  if (!r.match.plausible) return r;
  const std::vector<analysis::Recording> own = ofKind(recordings, cause.domain);
  const Extension e = cause.extend(study, depthsOf(own));
  if (e.parameters.empty()) throw ArgumentError("cause '" + cause.id + "': the study offers nothing to fit for it");
  r.fitted = true;
  const auto cases = casesOf(own);
  FoldOutcome folds;
  if (cases.size() >= 2) folds = crossValidate(e, cause.id, origin, own, model, settings);
  if (settings.on_stage) settings.on_stage("fitting " + cause.id + " on all cases");
  std::vector<analysis::Recording> runs;
  const CalibrationResult all = calibrate({e.study, origin, own, e.parameters}, model, settings.calibration);
  r.parameters = all.parameters;
  r.minima = static_cast<int>(all.minima.size());
  r.extended_study = all.calibrated_study;
  r.residuals = all.residuals;
  r.runs = all.calibrated_runs;
  r.chi2 = all.chi2;
  r.model_runs = folds.model_runs + all.model_runs;
  r.held_out = !folds.held_out_cases.empty();
  const std::string folds_used = std::to_string(folds.held_out_cases.size()) + " of " + std::to_string(cases.size()) + " folds";
  r.split = !r.held_out && cases.size() < 2 ? "one case only: ranked on all cases (in-sample)"
            : !r.held_out ? "no split can identify the extension (" + joined(folds.unidentified) + "): ranked on all cases (in-sample)"
            : folds.unidentified.empty()
                ? "leave one case out (" + std::to_string(cases.size()) + " folds)"
                : "leave one case out, " + folds_used + " (a split cannot identify " + joined(folds.unidentified) + ")";
  std::vector<Residual> before, before_all;
  for (const Residual& b : base.baseline_residuals) {
    if (b.key.kind != cause.domain) continue;
    before_all.push_back(b);
    if (!r.held_out || std::find(folds.held_out_cases.begin(), folds.held_out_cases.end(), b.key) != folds.held_out_cases.end())
      before.push_back(b);
  }
  r.error_before_percent = errorPercent(before);
  r.error_after_percent = errorPercent(r.held_out ? folds.held_out : all.residuals);
  r.gain_percent = r.error_before_percent > 0 ? 100 * (r.error_before_percent - r.error_after_percent) / r.error_before_percent : 0.0;
  const double n = static_cast<double>(all.residuals.size());
  r.bic = r.chi2 + static_cast<double>(e.parameters.size()) * std::log(n);
  r.delta_bic = r.bic - chi2(before_all);
  r.wall_time_s = secondsSince(start);
  return r;
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
                   const DiagnosisSettings& settings) {
  const auto start = Clock::now();
  Diagnosis d;
  d.measured = recordings;
  const std::vector<const Cause*> causes = candidates(recordings, settings);
  if (settings.on_stage) settings.on_stage("baseline prediction");
  // The baseline runs the whole stroke: the end-of-stroke signature compares like with like.
  CalibrationOptions whole_stroke = settings.calibration;
  whole_stroke.stroke_ends_with_window = false;
  d.baseline_residuals = predict(study, origin, recordings, model, whole_stroke, &d.baseline_runs);
  d.baseline_error_percent = errorPercent(d.baseline_residuals);
  d.baseline_chi2 = chi2(d.baseline_residuals);
  d.residual_count = static_cast<int>(d.baseline_residuals.size());
  const analysis::ComparisonResult comparison = analysis::compare(recordings, d.baseline_runs, settings.calibration.objective.analysis);
  d.signatures = analysis::signaturesOf(comparison, settings.signatures);
  for (const Cause* c : causes) d.ranking.push_back(assess(*c, d, study, origin, recordings, model, settings));
  rank(d.ranking);
  decide(d, study, settings);
  d.wall_time_s = secondsSince(start);
  return d;
}

}  // namespace demfem::campaign
