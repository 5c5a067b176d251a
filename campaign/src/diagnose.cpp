// The diagnosis procedure (diagnose.hpp): nominal prediction, calibrated baseline, the test of its
// residuals, one calibration per fold and model, evidence and verdict.
#include "demfem/campaign/diagnose.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <stdexcept>

namespace demfem::campaign {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::ordered_json;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", v);
  return buffer;
}

template <class T>
bool contains(const std::vector<T>& v, const T& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

// The residuals of the cases whose nominal run ran: a case the study as given cannot simulate (a DEM
// blow-up) says nothing about a discrepancy, and scoring its missing quantities as 0 would credit
// any extension whose runs happen not to fail.
std::vector<Residual> comparable(const std::vector<Residual>& residuals, const std::vector<analysis::CaseKey>& failed) {
  std::vector<Residual> out;
  for (const Residual& r : residuals)
    if (!contains(failed, r.key)) out.push_back(r);
  return out;
}

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

// The quantities the models are fitted and judged on: those of the candidates' signatures
// (Cause::judged_on; empty = every quantity).
std::vector<std::string> judgedQuantities(const std::vector<const Cause*>& causes) {
  std::vector<std::string> out;
  for (const Cause* c : causes) {
    if (c->judged_on.empty()) return {};
    for (const std::string& q : c->judged_on)
      if (!contains(out, q)) out.push_back(q);
  }
  return out;
}

// The model's seed scatter of every soil-bin quantity of `recordings` (diagnose.hpp, step 1): the
// study's runs at `seeds` deposition seeds (the first is the nominal run, from the run cache), per
// case and quantity the sample standard deviation of the seeds that ran.
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

// What every fit, test and evidence of one diagnosis shares.
struct Context {
  const ordered_json& study;
  const std::string& origin;
  const std::vector<analysis::Recording>& recordings;  // of the judged domain
  Model& model;
  const DiagnosisSettings& settings;
  CalibrationOptions fits;  // judged quantities, model-form tolerance
  std::vector<SeedScatter> seed_scatter;
  std::vector<analysis::CaseKey> failed;
};

// A residual's sigma of step 3: the fit's (measured scatter and model-form tolerance, objective.hpp)
// widened by the model's seed scatter of a mean over the fits' model seeds.
double testSigma(const Residual& r, const Context& c) {
  const auto it = std::find_if(c.seed_scatter.begin(), c.seed_scatter.end(),
                               [&](const SeedScatter& s) { return s.key == r.key && s.quantity == r.quantity; });
  const double model = it == c.seed_scatter.end() ? 0.0 : it->sd * it->sd / std::max(1, c.fits.model_seeds);
  return std::sqrt(r.sigma * r.sigma + model);
}

double testChi2(const std::vector<Residual>& residuals, const Context& c) {
  double sum = 0;
  for (const Residual& r : residuals) sum += std::pow((r.simulated - r.measured) / testSigma(r, c), 2);
  return sum;
}

double noiseErrorPercent(const std::vector<Residual>& residuals, const Context& c) {
  double sum = 0;
  int n = 0;
  for (const Residual& r : residuals) {
    if (r.measured == 0) continue;
    sum += std::pow(100 * testSigma(r, c) / r.measured, 2);
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

// Holm's step-down at the family-wise `level`: sets `significant` of the tests (each with `p_value`).
template <class Test>
void holm(std::vector<Test>& tests, double level) {
  std::vector<std::size_t> order(tests.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return tests[a].p_value < tests[b].p_value; });
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (tests[order[k]].p_value > level / static_cast<double>(order.size() - k)) break;
    tests[order[k]].significant = true;
  }
}

double twoSidedP(double z) { return std::erfc(std::abs(z) / std::numbers::sqrt2); }

// Step 3: z and two-sided p per residual, Holm's step-down at the family-wise level.
std::vector<Localisation> localise(const std::vector<Residual>& residuals, const Context& c) {
  std::vector<Localisation> out;
  for (const Residual& r : comparable(residuals, c.failed)) {
    Localisation l{r.key, r.quantity, r.measured, r.simulated, testSigma(r, c)};
    l.residual_percent = r.measured != 0 ? 100 * (r.simulated - r.measured) / r.measured : 0.0;
    l.z = (r.simulated - r.measured) / l.sigma;
    l.p_value = twoSidedP(l.z);
    out.push_back(l);
  }
  holm(out, c.settings.significance_level);
  return out;
}

// The window mean force's seed scatter of `key` relative to its mean, over sqrt(M) (0 unknown).
double relativeSeedScatter(const analysis::CaseKey& key, double window_mean_N, const Context& c) {
  for (const SeedScatter& s : c.seed_scatter)
    if (s.key == key && s.quantity == "window_mean_force_N" && window_mean_N != 0)
      return s.sd / std::abs(window_mean_N) / std::sqrt(std::max(1, c.fits.model_seeds));
  return 0.0;
}

// Step 3's localisation along the stroke for the soil-bin runs `runs` of `model` (PhaseLocalisation).
std::vector<PhaseLocalisation> localisePhases(const std::vector<analysis::Recording>& runs, const std::string& model, const Context& c) {
  std::vector<analysis::Recording> measured = ofKind(c.recordings, analysis::CaseKind::SoilBin), simulated = ofKind(runs, analysis::CaseKind::SoilBin);
  if (measured.empty() || simulated.empty()) return {};
  const auto& analysis = c.fits.objective.analysis;
  const analysis::ComparisonResult comparison = analysis::compare(measured, simulated, analysis);
  const double form = modelFormPercent(c.settings, "window_mean_force_N") / 100;
  std::vector<PhaseLocalisation> out;
  for (const analysis::StrokePhaseForce& f : analysis::strokePhaseForces(comparison, analysis.evaluation)) {
    if (contains(c.failed, f.key)) continue;
    PhaseLocalisation l;
    l.key = f.key;
    l.model = model;
    l.phase = analysis::phaseName(f.phase);
    l.measured_N = f.measured.mean_N;
    l.simulated_N = f.simulated.mean_N;
    const auto window = std::find_if(comparison.soil_bin.begin(), comparison.soil_bin.end(), [&](const auto& b) { return b.key == f.key; });
    const double seed = relativeSeedScatter(f.key, window->simulated.force_mean_N, c) * std::abs(f.simulated.mean_N);
    const double meas = f.measured.std_error_N.value_or(seed);
    const double sim = f.simulated.std_error_N.value_or(f.measured.std_error_N.value_or(seed));
    l.sigma_N = std::sqrt(meas * meas + sim * sim + std::pow(form * f.measured.mean_N, 2));
    l.residual_percent = f.measured.mean_N != 0 ? 100 * (f.simulated.mean_N - f.measured.mean_N) / f.measured.mean_N : 0.0;
    l.z = l.sigma_N > 0 ? (f.simulated.mean_N - f.measured.mean_N) / l.sigma_N : 0.0;
    l.p_value = twoSidedP(l.z);
    out.push_back(l);
  }
  holm(out, c.settings.significance_level);
  return out;
}

int significantCount(const std::vector<Residual>& residuals, const Context& c) {
  const auto l = localise(residuals, c);
  return static_cast<int>(std::count_if(l.begin(), l.end(), [](const Localisation& x) { return x.significant; }));
}

// The baseline's parameters with the causes' extensions: the extended study and every parameter,
// a cause's range replacing the baseline's for the same pointer.
Extension combined(const std::vector<const Cause*>& causes, const Context& c) {
  Extension out{c.study, c.settings.baseline_fit};
  for (const Cause* cause : causes) {
    const Extension e = cause->extend(out.study, depthsOf(c.recordings));
    if (e.parameters.empty()) throw ArgumentError("cause '" + cause->id + "': the study offers nothing to fit for it");
    out.study = e.study;
    for (const ParameterSpec& p : e.parameters) {
      const auto same = std::find_if(out.parameters.begin(), out.parameters.end(), [&](const ParameterSpec& q) { return q.pointer == p.pointer; });
      if (same == out.parameters.end()) out.parameters.push_back(p);
      else *same = p;
    }
  }
  return out;
}

// A fold's fit predicts its case when the data bound every parameter within the optimiser's box
// (calibration.hpp: sigma_x <= unidentified_fraction, no flat direction); a parameter known to
// worse than unidentified_relative of its value may still predict well, which the held-out error
// then measures.
CalibrationOptions foldFits(CalibrationOptions options) {
  options.unidentified_relative = std::numeric_limits<double>::infinity();
  return options;
}

// Leave one case out: fit on the others, predict the one. A fold whose fit leaves a parameter
// unidentified predicts nothing and is listed in `unidentified`.
void crossValidate(const Extension& e, const std::string& id, const Context& c, ModelFit& fit, std::vector<std::string>& unidentified) {
  const auto cases = casesOf(c.recordings);
  if (cases.size() < 2) return;
  for (std::size_t f = 0; f < cases.size(); ++f) {
    if (c.settings.on_stage) c.settings.on_stage("fitting " + id + ", fold " + std::to_string(f + 1) + "/" + std::to_string(cases.size()));
    CalibrationProblem problem{e.study, c.origin, {}, e.parameters};
    std::vector<analysis::Recording> test;
    for (const auto& r : c.recordings) (r.key == cases[f] ? test : problem.recordings).push_back(r);
    const CalibrationResult trained = calibrate(problem, c.model, foldFits(c.fits));
    fit.model_runs += trained.model_runs;
    const auto loose = std::find_if(trained.parameters.begin(), trained.parameters.end(), [](const FittedParameter& p) { return !p.identified; });
    if (loose != trained.parameters.end()) {
      unidentified.push_back(loose->spec.label() + " without the case " + cases[f].title());
      continue;
    }
    const auto predicted = predict(trained.calibrated_study, c.origin, test, c.model, c.fits);
    fit.held_out.insert(fit.held_out.end(), predicted.begin(), predicted.end());
    fit.held_out_cases.push_back(cases[f]);
  }
}

// ln of the Gaussian volume of the fit inside the unit prior box (step 4): per eigen direction of
// J^T J, sqrt(2 pi / lambda), at most the box's width 1 (a flat direction costs nothing).
double logOccam(const std::vector<double>& eigenvalues) {
  double sum = 0;
  for (double lambda : eigenvalues)
    if (lambda > 0) sum += std::min(0.0, 0.5 * std::log(2 * std::numbers::pi / lambda));
  return sum;
}

std::string joined(const std::vector<std::string>& parts, const std::string& separator) {
  std::string s;
  for (const auto& p : parts) s += (s.empty() ? "" : separator) + p;
  return s;
}

// Fits one model (steps 2, 4): on all cases and per fold; its chi2, evidence and significant residuals.
ModelFit fitModel(const std::vector<const Cause*>& causes, const Context& c) {
  const auto start = Clock::now();
  ModelFit fit;
  for (const Cause* cause : causes) fit.causes.push_back(cause->id);
  const Extension e = combined(causes, c);
  std::vector<std::string> unidentified;
  crossValidate(e, fit.id(), c, fit, unidentified);
  if (c.settings.on_stage) c.settings.on_stage("fitting " + fit.id() + " on all cases");
  const CalibrationResult all = calibrate({e.study, c.origin, c.recordings, e.parameters}, c.model, c.fits);
  fit.parameters = all.parameters;
  fit.minima = static_cast<int>(all.minima.size());
  fit.extended_study = all.calibrated_study;
  fit.residuals = all.residuals;
  fit.runs = all.calibrated_runs;
  fit.model_runs += all.model_runs;
  fit.held_out_folds = static_cast<int>(fit.held_out_cases.size());
  const std::size_t cases = casesOf(c.recordings).size();
  fit.split = cases < 2 ? "one case only: in-sample"
              : !fit.heldOut() ? "no split can identify it (" + joined(unidentified, "; ") + "): in-sample"
              : unidentified.empty() ? "leave one case out (" + std::to_string(cases) + " folds)"
                                     : "leave one case out, " + std::to_string(fit.held_out_folds) + " of " + std::to_string(cases) +
                                           " folds (a split cannot identify " + joined(unidentified, "; ") + ")";
  const std::vector<Residual> fitted = comparable(all.residuals, c.failed);
  fit.chi2 = testChi2(fitted, c);
  fit.log_likelihood = -fit.chi2 / 2;
  fit.log_occam = logOccam(all.curvature_eigenvalues);
  fit.log_evidence = fit.log_likelihood + fit.log_occam;
  fit.significant = significantCount(fitted, c);
  fit.wall_time_s = secondsSince(start);
  return fit;
}

// Step 5 for `fit` against the calibrated baseline's folds.
void measureBenefit(ModelFit& fit, const ModelFit& baseline, const Context& c) {
  std::vector<Residual> before, after;
  if (fit.heldOut()) {
    for (const Residual& r : comparable(baseline.held_out, c.failed))
      if (contains(fit.held_out_cases, r.key)) before.push_back(r);
    after = comparable(fit.held_out, c.failed);
  } else {
    before = comparable(baseline.residuals, c.failed);
    after = comparable(fit.residuals, c.failed);
  }
  fit.error_before_percent = errorPercent(before);
  fit.error_after_percent = errorPercent(after);
  fit.noise_error_percent = noiseErrorPercent(before, c);
  const double resolved_after = std::max(fit.error_after_percent, fit.noise_error_percent);
  fit.gain_percent = fit.error_before_percent > 0 ? 100 * (fit.error_before_percent - resolved_after) / fit.error_before_percent : 0.0;
  fit.held_out_chi2_before = testChi2(before, c);
  fit.held_out_chi2_after = testChi2(after, c);
  const double expected = static_cast<double>(after.size());
  fit.chi2_gain_percent = fit.held_out_chi2_before > 0
                              ? 100 * (fit.held_out_chi2_before - std::max(fit.held_out_chi2_after, expected)) / fit.held_out_chi2_before
                              : 0.0;
  fit.ln_bayes_factor = fit.log_evidence - baseline.log_evidence;
}

// Posterior probabilities of the baseline and the models (equal prior odds, step 4); models sorted
// most probable first.
void posterior(ModelFit& baseline, std::vector<ModelFit>& models) {
  double top = baseline.log_evidence;
  for (const ModelFit& m : models) top = std::max(top, m.log_evidence);
  double sum = std::exp(baseline.log_evidence - top);
  for (const ModelFit& m : models) sum += std::exp(m.log_evidence - top);
  baseline.probability = std::exp(baseline.log_evidence - top) / sum;
  for (ModelFit& m : models) m.probability = std::exp(m.log_evidence - top) / sum;
  std::stable_sort(models.begin(), models.end(), [](const ModelFit& a, const ModelFit& b) { return a.log_evidence > b.log_evidence; });
}

// Whether one cause's parameters are all among the other's (mass_damping within damping_form): the
// pair is the larger cause alone.
bool redundantPair(const Cause& a, const Cause& b, const Context& c) {
  const auto pointers = [&](const Cause& x) {
    std::set<std::string> out;
    for (const ParameterSpec& p : x.extend(c.study, depthsOf(c.recordings)).parameters) out.insert(p.pointer);
    return out;
  };
  const auto pa = pointers(a), pb = pointers(b);
  return std::includes(pa.begin(), pa.end(), pb.begin(), pb.end()) || std::includes(pb.begin(), pb.end(), pa.begin(), pa.end());
}

// Whether `cause` is a pair partner (step 4): with settings.all_pairs every cause, otherwise those
// whose single fit has evidence above the baseline's (ln B > 0).
bool partner(const Cause& cause, const std::vector<ModelFit>& singles, const ModelFit& baseline, const Context& c) {
  if (c.settings.all_pairs) return true;
  const auto it = std::find_if(singles.begin(), singles.end(), [&](const ModelFit& m) { return m.causes.front() == cause.id; });
  return it != singles.end() && it->log_evidence > baseline.log_evidence;
}

// Step 4's pairs: each of the two most probable single causes with every partner.
std::vector<ModelFit> fitPairs(const std::vector<ModelFit>& singles, const ModelFit& baseline, const std::vector<const Cause*>& causes,
                               const Context& c) {
  std::vector<ModelFit> out;
  std::set<std::set<std::string>> done;
  for (std::size_t k = 0; k < std::min<std::size_t>(2, singles.size()); ++k) {
    const Cause& first = findCause(singles[k].causes.front());
    for (const Cause* other : causes) {
      if (other->id == first.id || !partner(*other, singles, baseline, c) || !done.insert({first.id, other->id}).second ||
          redundantPair(first, *other, c))
        continue;
      out.push_back(fitModel({&first, other}, c));
    }
  }
  return out;
}

// "quantity Q at case C: x % off, n standard errors; ..." for the significant residuals.
std::string significantText(const std::vector<Localisation>& localisation) {
  std::string text;
  for (const Localisation& l : localisation)
    if (l.significant)
      text += (text.empty() ? "" : "; ") + l.quantity + " at " + l.key.title() + ": " + number(l.residual_percent) + " % off, " +
              number(std::abs(l.z)) + " standard errors";
  return text;
}

const Localisation& largest(const std::vector<Localisation>& localisation) {
  return *std::max_element(localisation.begin(), localisation.end(), [](const auto& a, const auto& b) { return std::abs(a.z) < std::abs(b.z); });
}

// Step 7's conditions for naming `m` ("" when it qualifies, else why not).
std::string notNamed(const ModelFit& m, const DiagnosisSettings& s) {
  if (m.ln_bayes_factor < s.min_ln_bayes_factor)
    return "ln B " + number(m.ln_bayes_factor) + " < " + number(s.min_ln_bayes_factor);
  if (m.significant > 0) return std::to_string(m.significant) + " residual(s) still significant";
  if (m.heldOut() && m.held_out_folds < s.min_held_out_folds)
    return "predicts " + std::to_string(m.held_out_folds) + " held-out case(s), fewer than " + std::to_string(s.min_held_out_folds);
  if (m.heldOut() && m.chi2_gain_percent < s.min_gain_percent)
    return "held-out chi2 gain " + number(m.chi2_gain_percent) + " % < " + number(s.min_gain_percent) + " %";
  return "";
}

void decide(Diagnosis& d, const DiagnosisSettings& s) {
  d.extended_study = d.baseline.extended_study;
  const std::size_t tests = d.localisation.size();
  if (std::none_of(d.localisation.begin(), d.localisation.end(), [](const Localisation& l) { return l.significant; })) {
    d.verdict = Verdict::NoSignificantDiscrepancy;
    const Localisation& top = d.localisation.empty() ? Localisation{} : largest(d.localisation);
    d.reason = "every quantity of the calibrated baseline is within noise (Holm, family-wise level " + number(s.significance_level) +
               " over " + std::to_string(tests) + " residuals; largest: " + top.quantity + " at " + top.key.title() + ", " +
               number(top.residual_percent) + " %, " + number(std::abs(top.z)) + " standard errors)";
    return;
  }
  for (std::size_t k = 0; k < d.models.size(); ++k)
    if (const ModelFit& m = d.models[k]; notNamed(m, s).empty()) {
      d.verdict = Verdict::Cause;
      d.named_model = k;
      d.causes = m.causes;
      d.gain_percent = m.gain_percent;
      d.extended_study = m.extended_study;
      d.reason = m.id() + ": ln B " + number(m.ln_bayes_factor) + " over the calibrated baseline (probability " + number(m.probability) +
                 "), no residual left significant, " +
                 (m.heldOut() ? "held-out error " + number(m.error_before_percent) + " % -> " + number(m.error_after_percent) + " % (gain " +
                                    number(m.gain_percent) + " %, chi2 " + number(m.held_out_chi2_before) + " -> " + number(m.held_out_chi2_after) + ")"
                              : m.split + ", judged on its evidence");
      return;
    }
  d.verdict = Verdict::UnexplainedDiscrepancy;
  const std::string best = d.models.empty() ? std::string("no cause fitted") : "best " + d.models.front().id() + ": " + notNamed(d.models.front(), s);
  const bool others_within = std::any_of(d.localisation.begin(), d.localisation.end(), [](const Localisation& l) { return !l.significant; });
  d.reason = significantText(d.localisation) + (others_within ? "; the other quantities within noise" : "") +
             "; no cause or pair of the catalogue explains it (" + best + ")";
}

// The catalogue cause among `causes` whose extension fits `pointer` alone ("" none).
std::string soleOwner(const std::string& pointer, const std::vector<const Cause*>& causes, const Context& c) {
  for (const Cause* cause : causes) {
    try {
      const Extension e = cause->extend(c.study, depthsOf(c.recordings));
      if (e.parameters.size() == 1 && e.parameters.front().pointer == pointer) return cause->id;
    } catch (const ArgumentError&) {  // the study cannot take this cause: it owns nothing here
    }
  }
  return "";
}

// Step 6: the baseline parameters of `fit` against the study's values.
std::vector<CalibrationShift> calibrationShifts(const ModelFit& fit, const std::vector<const Cause*>& causes, const Context& c) {
  std::vector<CalibrationShift> out;
  for (const ParameterSpec& base : c.settings.baseline_fit) {
    const auto p = std::find_if(fit.parameters.begin(), fit.parameters.end(), [&](const FittedParameter& q) { return q.spec.pointer == base.pointer; });
    if (p == fit.parameters.end()) continue;
    CalibrationShift shift;
    shift.spec = p->spec;
    shift.study_value = p->initial;
    shift.fitted = p->best;
    shift.std_dev = p->std_dev;
    shift.model_form_shift = p->model_form_shift;
    shift.shift_percent = p->initial != 0 ? 100 * (p->best - p->initial) / p->initial : 0.0;
    const double sigma = std::hypot(p->std_dev, p->model_form_shift);
    shift.z = p->identified && std::isfinite(sigma) && sigma > 0 ? (p->best - p->initial) / sigma : 0.0;
    shift.p_value = twoSidedP(shift.z);
    shift.cause = soleOwner(base.pointer, causes, c);
    out.push_back(shift);
  }
  holm(out, c.settings.significance_level);
  return out;
}

std::string shiftText(const CalibrationShift& s) {
  return s.spec.label() + " " + (s.shift_percent >= 0 ? "+" : "") + number(s.shift_percent) + " % from the study's " + number(s.study_value) + " (" +
         number(std::abs(s.z)) + " standard errors): `" + s.cause + "`";
}

// Step 6's causes added to the verdict of step 7.
void creditShifts(Diagnosis& d, const std::vector<const Cause*>& causes, const Context& c) {
  d.shifts = calibrationShifts(d.named_model ? d.models[*d.named_model] : d.baseline, causes, c);
  std::string credited;
  for (const CalibrationShift& s : d.shifts) {
    if (!s.significant || s.cause.empty() || contains(d.causes, s.cause)) continue;
    d.causes.push_back(s.cause);
    credited += (credited.empty() ? "" : "; ") + shiftText(s);
  }
  if (credited.empty()) return;
  switch (d.verdict) {
    case Verdict::NoSignificantDiscrepancy:
      d.verdict = Verdict::Cause;
      d.gain_percent = d.nominal_error_percent > 0
                           ? 100 * (d.nominal_error_percent - std::max(d.baseline.error_after_percent, d.baseline.noise_error_percent)) /
                                 d.nominal_error_percent
                           : 0.0;
      d.reason = "the calibrated baseline moved " + credited + "; with it " + d.reason;
      return;
    case Verdict::Cause:
      d.reason += "; the calibration moved " + credited;
      return;
    case Verdict::UnexplainedDiscrepancy:
      d.causes.clear();  // a residual no model explains: no cause is named, the shifts are reported
      return;
  }
}

}  // namespace

std::string verdictText(Verdict verdict) {
  switch (verdict) {
    case Verdict::NoSignificantDiscrepancy:
      return "no significant discrepancy";
    case Verdict::Cause:
      return "cause";
    case Verdict::UnexplainedDiscrepancy:
      return "unexplained discrepancy";
  }
  return "unknown";
}

double modelFormPercent(const DiagnosisSettings& settings, const std::string& quantity) {
  const auto it = settings.model_form_percent.find(quantity);
  return it != settings.model_form_percent.end() ? it->second : settings.model_form_percent.at("");
}

std::string ModelFit::id() const { return causes.empty() ? "baseline" : joined(causes, "+"); }

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

namespace {

// Beyond the widest factor by which a catalogue cause moves a weight's steady load-cell force or
// deformation (the sensor gains' range, 0.7-1.4, and the clamp's, docs/diagnosis.md): a recording
// further off than kImpossibleFactor is a unit mistake or another tool, never a discrepancy.
constexpr double kImpossibleFactor = 5.0;

// Refuses weight recordings no model of the catalogue could produce (docs/reliability.md, "Inputs
// checked against physics"), naming their files, the quantity and the factor.
void refuseImpossible(const analysis::Signatures& signatures, const std::vector<analysis::Recording>& recordings) {
  for (const analysis::WeightDropSignature& w : signatures.weight_drops) {
    for (const auto& [name, ratio] : {std::pair<std::string, double>{"steady load-cell force", w.force_ratio.value},
                                      {"steady deformation", w.deformation_ratio.value}}) {
      if (!std::isfinite(ratio) || (ratio >= 1 / kImpossibleFactor && ratio <= kImpossibleFactor)) continue;
      std::string files;
      for (const analysis::Recording& r : recordings)
        if (r.key == w.key) files += (files.empty() ? "" : ", ") + r.sidecar_path.string();
      throw ArgumentError(files + ": the measured " + name + " of " + w.key.title() + " is " + number(ratio) +
                          " times the model's, beyond the factor " + number(kImpossibleFactor) +
                          " any cause of the catalogue can explain: check the sidecars' mass_kg and calibration factors");
    }
  }
}

}  // namespace

Diagnosis diagnose(const ordered_json& study, const std::string& origin, const std::vector<analysis::Recording>& recordings, Model& model,
                   const DiagnosisSettings& given) {
  const auto start = Clock::now();
  // The model's seed scatter is measured here (step 1) and widens the test; the fits keep the
  // measured sigma so that it is not counted twice.
  DiagnosisSettings settings = given;
  settings.calibration.model_scatters_like_repeats = false;
  Diagnosis d;
  d.measured = recordings;
  const std::vector<const Cause*> causes = candidates(recordings, settings);
  const analysis::CaseKind domain = causes.front()->domain;
  const std::vector<analysis::Recording> own = ofKind(recordings, domain);
  if (settings.baseline_fit.empty()) settings.baseline_fit = baselineParameters(study, origin, own, domain);
  if (settings.on_stage) settings.on_stage("nominal prediction");
  // The nominal prediction runs the whole stroke: the end-of-stroke signature compares like with like.
  CalibrationOptions whole_stroke = settings.calibration;
  whole_stroke.stroke_ends_with_window = false;
  d.nominal_residuals = predict(study, origin, recordings, model, whole_stroke, &d.nominal_runs);
  for (const Residual& r : d.nominal_residuals)
    if (r.missing && !contains(d.failed_baseline_cases, r.key)) d.failed_baseline_cases.push_back(r.key);
  const std::vector<Residual> ran = comparable(d.nominal_residuals, d.failed_baseline_cases);
  if (ran.empty()) throw std::runtime_error("diagnose: the study as given fails (DEM blow-up) on every case; nothing to compare");
  d.nominal_error_percent = errorPercent(ran);
  if (settings.on_stage && settings.scatter_seeds > 1) settings.on_stage("the model's seed scatter");
  d.seed_scatter = seedScatter(study, origin, recordings, model, whole_stroke, settings.scatter_seeds);
  d.signatures = analysis::signaturesOf(analysis::compare(recordings, d.nominal_runs, settings.calibration.objective.analysis), settings.signatures);
  refuseImpossible(d.signatures, recordings);
  for (const Cause* c : causes)
    d.considered.push_back({c->id, c->description, c->expected_signature, c->judged_on, c->match(d.signatures, settings.tolerance)});

  Context c{study, origin, own, model, settings, settings.calibration, d.seed_scatter, d.failed_baseline_cases};
  c.fits.objective.only_quantities = judgedQuantities(causes);
  for (const std::string& name : quantityNames()) c.fits.objective.model_form_relative[name] = modelFormPercent(settings, name) / 100;
  d.baseline = fitModel({}, c);
  measureBenefit(d.baseline, d.baseline, c);
  d.localisation = localise(d.baseline.residuals, c);
  d.phases = localisePhases(d.nominal_runs, "study as given", c);
  for (const PhaseLocalisation& l : localisePhases(d.baseline.runs, "calibrated baseline", c)) d.phases.push_back(l);
  for (const std::string& name : quantityNames()) {
    std::vector<Residual> of;
    for (const Residual& r : ran)
      if (r.quantity == name && !c.fits.objective.only_quantities.empty() && !contains(c.fits.objective.only_quantities, name)) of.push_back(r);
    if (!of.empty()) d.unjudged.push_back({name, errorPercent(of)});
  }
  // Signatures order the work (present first); every cause is fitted.
  std::vector<const Cause*> ordered = causes;
  std::stable_partition(ordered.begin(), ordered.end(), [&](const Cause* x) { return x->match(d.signatures, settings.tolerance).plausible; });
  for (const Cause* cause : ordered) d.models.push_back(fitModel({cause}, c));
  posterior(d.baseline, d.models);
  if (settings.pairs && !d.models.empty() && d.models.front().significant > 0) {
    std::vector<ModelFit> pairs = fitPairs(d.models, d.baseline, causes, c);
    d.models.insert(d.models.end(), pairs.begin(), pairs.end());
    posterior(d.baseline, d.models);
  }
  for (ModelFit& m : d.models) measureBenefit(m, d.baseline, c);
  decide(d, settings);
  creditShifts(d, causes, c);
  d.wall_time_s = secondsSince(start);
  return d;
}

}  // namespace demfem::campaign
