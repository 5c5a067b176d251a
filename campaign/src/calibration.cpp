#include "demfem/campaign/calibration.hpp"

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/campaign/run_cache.hpp"

#include <Eigen/Eigenvalues>
#include <nlopt.hpp>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <thread>

namespace demfem::campaign {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::vector<analysis::CaseKey> casesOf(const std::vector<analysis::Recording>& recordings) {
  std::set<analysis::CaseKey> keys;
  for (const auto& r : recordings) keys.insert(r.key);
  return {keys.begin(), keys.end()};
}

struct Evaluation {
  std::vector<Residual> residuals;
  std::vector<analysis::Recording> runs;
  double chi2 = 0;
};

// Runs the model for every case at given parameter values, through the run cache, cases in parallel.
class Evaluator {
 public:
  Evaluator(const nlohmann::ordered_json& study, std::string origin, const std::vector<analysis::Recording>& recordings,
            std::vector<ParameterSpec> specs, Model& model, const CalibrationOptions& options)
      : study_(study), origin_(std::move(origin)), specs_(std::move(specs)), model_(model), options_(options),
        cases_(casesOf(recordings)) {
    for (const auto& key : cases_) caseStudy(study_, origin_, key);  // every case runnable (ArgumentError otherwise)
    measured_ = quantities(recordings, options.objective, false);
    if (options.kind == ObjectiveKind::Noisy && options.model_scatters_like_repeats)
      for (Quantity& q : measured_) q.sigma = std::hypot(q.sigma, q.repeat_sd / std::sqrt(std::max(1, options.model_seeds)));
    if (!options.cache_dir.empty()) cache_.emplace(options.cache_dir);
    scratch_ = options.cache_dir.empty() ? fs::temp_directory_path() / ("demfem-calibrate-" + std::to_string(getpid()))
                                         : options.cache_dir / ("scratch-" + std::to_string(getpid()));  // one per process: a cache may be shared
  }

  ~Evaluator() {
    std::error_code ec;
    if (options_.cache_dir.empty()) fs::remove_all(scratch_, ec);  // a private temporary directory
  }
  Evaluator(const Evaluator&) = delete;
  Evaluator& operator=(const Evaluator&) = delete;

  const Evaluation& at(const std::vector<double>& values) {
    {
      std::lock_guard lock(mutex_);
      if (auto it = memo_.find(values); it != memo_.end()) return it->second;
    }
    if (options_.stop_requested && options_.stop_requested()) throw Interrupted("calibration interrupted (finished runs are kept in the run cache)");
    Evaluation e;
    e.runs = runAll(withValues(study_, specs_, values));
    std::erase_if(e.runs, [](const analysis::Recording& r) { return r.size() == 0; });  // failed runs: quantities missing
    e.residuals = residuals(measured_, quantities(e.runs, options_.objective, true));
    e.chi2 = chi2(e.residuals);
    ++evaluations_;
    std::lock_guard lock(mutex_);
    return memo_.emplace(values, std::move(e)).first->second;
  }

  int evaluations() const { return evaluations_; }
  int modelRuns() const { return model_runs_; }
  int cacheHits() const { return cache_hits_; }
  int failedRuns() const { return failed_runs_; }
  const std::vector<ParameterSpec>& specs() const { return specs_; }

 private:
  // The study of each model seed: the study itself, or with model_seeds > 1 for a soil study its
  // deposition seeds s0 .. s0 + model_seeds - 1 (s0 the study's).
  std::vector<nlohmann::ordered_json> seedVariants(const nlohmann::ordered_json& study) const {
    if (options_.model_seeds <= 1 || !study.contains("soil")) return {study};
    const auto seed = nlohmann::ordered_json::json_pointer("/soil/deposition/seed");
    const std::uint64_t s0 = study.contains(seed) ? study.at(seed).get<std::uint64_t>() : 1;
    std::vector<nlohmann::ordered_json> out;
    for (int k = 0; k < options_.model_seeds; ++k) {
      out.push_back(study);
      out.back()[seed] = s0 + static_cast<std::uint64_t>(k);
    }
    return out;
  }

  // Every case at every model seed; the runs of one case are pooled like measured repeats.
  std::vector<analysis::Recording> runAll(const nlohmann::ordered_json& study) {
    const std::vector<nlohmann::ordered_json> variants = seedVariants(study);
    std::vector<std::pair<const nlohmann::ordered_json*, const analysis::CaseKey*>> items;
    for (const auto& key : cases_)
      for (const auto& v : variants) items.emplace_back(&v, &key);
    std::vector<study::Study> to_run;
    for (const auto& [v, key] : items)
      if (study::Study s = studyOf(*v, *key); !cache_ || !cache_->find(model_.name(), s, *key)) to_run.push_back(std::move(s));
    if (!to_run.empty()) model_.prepare(to_run, options_.on_deposit);
    std::vector<analysis::Recording> out(items.size());
    std::vector<std::exception_ptr> errors(items.size());
    std::atomic<std::size_t> next{0};
    const auto worker = [&] {
      for (std::size_t i; (i = next++) < items.size();) {
        try {
          out[i] = runCase(*items[i].first, *items[i].second);
          out[i].repeat = static_cast<int>(i % variants.size()) + 1;  // the model seed's repeat number
        } catch (const adapter::CouplingError& e) {
          // A DEM run that failed (a blow-up at an extreme parameter value) scores like a run that
          // cannot be evaluated (objective.hpp); other errors stop the calibration.
          if (e.code() != adapter::ErrorCode::SimulationFailed) errors[i] = std::current_exception();
          else ++failed_runs_;
        } catch (...) {
          errors[i] = std::current_exception();
        }
      }
    };
    const std::size_t threads = std::min<std::size_t>(static_cast<std::size_t>(std::max(1, options_.jobs)), items.size());
    std::vector<std::thread> pool;
    for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
    for (const auto& e : errors)
      if (e) std::rethrow_exception(e);
    return out;
  }

  study::Study studyOf(const nlohmann::ordered_json& study_json, const analysis::CaseKey& key) const {
    return caseStudy(study_json, origin_, key,
                     options_.stroke_ends_with_window ? std::optional(options_.objective.analysis.evaluation.window_end_mm) : std::nullopt);
  }

  analysis::Recording runCase(const nlohmann::ordered_json& study_json, const analysis::CaseKey& key) {
    const study::Study study = studyOf(study_json, key);
    if (cache_)
      if (auto hit = cache_->find(model_.name(), study, key)) {
        ++cache_hits_;
        return *hit;
      }
    const fs::path scratch = scratch_ / RunCache::key(model_.name(), study, key);
    fs::create_directories(scratch);
    analysis::Recording rec = model_.run(study, key, scratch);
    std::error_code ec;
    fs::remove_all(scratch, ec);
    ++model_runs_;
    if (cache_) cache_->store(model_.name(), study, key, rec);
    return rec;
  }

  nlohmann::ordered_json study_;
  std::string origin_;
  std::vector<ParameterSpec> specs_;
  Model& model_;
  const CalibrationOptions& options_;
  std::vector<analysis::CaseKey> cases_;
  std::vector<Quantity> measured_;
  std::optional<RunCache> cache_;
  fs::path scratch_;
  std::mutex mutex_;
  std::map<std::vector<double>, Evaluation> memo_;
  std::atomic<int> evaluations_{0}, model_runs_{0}, cache_hits_{0}, failed_runs_{0};
};

std::vector<double> valuesOf(const std::vector<ParameterSpec>& specs, const std::vector<double>& x) {
  std::vector<double> v;
  for (std::size_t i = 0; i < specs.size(); ++i) v.push_back(specs[i].toValue(x[i]));
  return v;
}

// Radical inverse of `index` in `base`: the Halton sequence's coordinate.
double halton(int index, int base) {
  double result = 0, f = 1;
  for (int i = index; i > 0; i /= base) {
    f /= base;
    result += f * (i % base);
  }
  return result;
}

std::vector<double> startPoint(int start, const std::vector<double>& initial_x) {
  static constexpr int kPrimes[] = {2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37};
  if (start == 0) return initial_x;
  std::vector<double> x;
  for (std::size_t i = 0; i < initial_x.size(); ++i) x.push_back(halton(start, kPrimes[i % std::size(kPrimes)]));
  return x;
}

struct LocalMinimum {
  std::vector<double> x;
  double chi2 = 0;
};

class Search {
 public:
  Search(Evaluator& evaluator, const CalibrationOptions& options, int n, Clock::time_point begin)
      : evaluator_(evaluator), options_(options), n_(n), begin_(begin) {}

  LocalMinimum run(int start, const std::vector<double>& x0) {
    start_ = start;
    const nlopt::algorithm algorithm = options_.kind == ObjectiveKind::Noisy ? nlopt::LN_SBPLX
                                       : n_ >= 2                            ? nlopt::LN_BOBYQA
                                                                            : nlopt::LN_COBYLA;
    nlopt::opt opt(algorithm, static_cast<unsigned>(n_));
    opt.set_lower_bounds(std::vector<double>(n_, 0.0));
    opt.set_upper_bounds(std::vector<double>(n_, 1.0));
    opt.set_xtol_abs(options_.x_tolerance);
    opt.set_maxeval(options_.max_evaluations);
    opt.set_initial_step(0.1);
    opt.set_min_objective(&Search::objective, this);
    opt_ = &opt;
    std::vector<double> x = x0;
    double f = 0;
    try {
      opt.optimize(x, f);
    } catch (const nlopt::roundoff_limited&) {
      // converged as far as round-off allows: x holds the best point
    } catch (const nlopt::forced_stop&) {
    }
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
    return {x, evaluator_.at(valuesOf(evaluator_.specs(), x)).chi2};
  }

 private:
  static double objective(unsigned, const double* x, double*, void* data) {
    auto* self = static_cast<Search*>(data);
    try {
      const std::vector<double> unit(x, x + self->n_);
      const double value = self->evaluator_.at(valuesOf(self->evaluator_.specs(), unit)).chi2;
      self->best_ = std::min(self->best_, value);
      self->report();
      return value;
    } catch (...) {
      self->error_ = std::current_exception();
      self->opt_->force_stop();
      return std::numeric_limits<double>::max();
    }
  }

  void report() {
    if (!options_.on_progress) return;
    CalibrationProgress p;
    p.evaluation = evaluator_.evaluations();
    p.max_evaluations = options_.max_evaluations * options_.starts;
    p.start = start_ + 1;
    p.starts = options_.starts;
    p.best_chi2 = best_;
    p.elapsed_s = std::chrono::duration<double>(Clock::now() - begin_).count();
    p.eta_s = p.evaluation > 0 ? p.elapsed_s / p.evaluation * std::max(0, p.max_evaluations - p.evaluation) : 0;
    options_.on_progress(p);
  }

  Evaluator& evaluator_;
  const CalibrationOptions& options_;
  int n_;
  int start_ = 0;
  nlopt::opt* opt_ = nullptr;
  std::exception_ptr error_;
  double best_ = std::numeric_limits<double>::infinity();
  Clock::time_point begin_;  // of the calibration (elapsed and eta include the first evaluation)
};

// One-sigma widths in optimiser coordinates from the Gauss-Newton curvature at x (contract).
// Per parameter the standard deviation in optimiser coordinates (infinite along a flat direction),
// and the eigenvalues of J^T J in `eigenvalues`.
// Per parameter, in optimiser units: its standard deviation sqrt((J^T J)^-1_ii) (infinite along a flat
// direction) and its model-form shift sum_k |G_ik| f_k, G = (J^T J)^+ J^T, f_k the model-form part of
// residual k's sigma in its own units (objective.hpp): the largest move a model-form error of the
// stated tolerance, coherent over the residuals, makes in a linearised fit.
struct UnitSigmas {
  std::vector<double> sigma, model_form;
};

UnitSigmas unitSigmas(Evaluator& evaluator, const std::vector<double>& x, const CalibrationOptions& options, std::vector<double>& eigenvalues) {
  const double step = options.curvature_step;
  const auto& specs = evaluator.specs();
  const auto& at_fit = evaluator.at(valuesOf(specs, x)).residuals;
  const auto m = static_cast<Eigen::Index>(at_fit.size());
  Eigen::VectorXd form(m);
  for (Eigen::Index k = 0; k < m; ++k) {
    const auto it = options.objective.model_form_relative.find(at_fit[k].quantity);
    const double relative = it == options.objective.model_form_relative.end() ? 0.0 : it->second;
    form(k) = at_fit[k].sigma > 0 ? relative * std::abs(at_fit[k].measured) / at_fit[k].sigma : 0.0;
  }
  const auto n = static_cast<Eigen::Index>(x.size());
  Eigen::MatrixXd J(m, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    std::vector<double> lo = x, hi = x;
    lo[i] = std::max(0.0, x[i] - step);
    hi[i] = std::min(1.0, x[i] + step);
    const auto& r_lo = evaluator.at(valuesOf(specs, lo)).residuals;
    const auto& r_hi = evaluator.at(valuesOf(specs, hi)).residuals;
    for (Eigen::Index k = 0; k < m; ++k) J(k, i) = (r_hi[k].normalized - r_lo[k].normalized) / (hi[i] - lo[i]);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(J.transpose() * J);
  eigenvalues.assign(eig.eigenvalues().data(), eig.eigenvalues().data() + n);
  const double largest = eig.eigenvalues().cwiseAbs().maxCoeff();
  std::vector<double> sigma(n, 0.0);
  Eigen::MatrixXd pseudo_inverse = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double lambda = eig.eigenvalues()(k);
    const bool flat = !(lambda > 1e-12 * largest) || !(lambda > 0);
    if (!flat) pseudo_inverse += eig.eigenvectors().col(k) * eig.eigenvectors().col(k).transpose() / lambda;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double v = eig.eigenvectors()(i, k);
      sigma[i] += flat ? (std::abs(v) > 1e-6 ? std::numeric_limits<double>::infinity() : 0.0) : v * v / lambda;
    }
  }
  for (double& s : sigma) s = std::sqrt(s);
  const Eigen::MatrixXd gain = pseudo_inverse * J.transpose();
  std::vector<double> model_form(n);
  for (Eigen::Index i = 0; i < n; ++i) model_form[i] = gain.row(i).cwiseAbs().dot(form);
  return {sigma, model_form};
}

double toFileSigma(const ParameterSpec& spec, double value, double sigma_x) {
  return spec.log ? value * std::log(spec.hi / spec.lo) * sigma_x : (spec.hi - spec.lo) * sigma_x;
}

std::vector<Minimum> distinctMinima(const std::vector<LocalMinimum>& found, const LocalMinimum& best, const std::vector<double>& sigma,
                                    const std::vector<ParameterSpec>& specs, double noise_chi2) {
  std::vector<LocalMinimum> kept{best};
  for (const auto& candidate : found) {
    if (candidate.chi2 > best.chi2 + noise_chi2) continue;
    bool distinct = true;
    for (const auto& k : kept) {
      bool apart = false;
      for (std::size_t i = 0; i < sigma.size(); ++i)
        if (std::isfinite(sigma[i]) && std::abs(candidate.x[i] - k.x[i]) > 3 * sigma[i]) apart = true;
      distinct = distinct && apart;
    }
    if (distinct) kept.push_back(candidate);
  }
  std::vector<Minimum> out;
  for (const auto& k : kept) out.push_back({valuesOf(specs, k.x), k.chi2});
  return out;
}

}  // namespace

CalibrationResult calibrate(const CalibrationProblem& problem, Model& model, const CalibrationOptions& options) {
  const auto begin = Clock::now();
  if (problem.parameters.empty()) throw ArgumentError("calibrate: no parameter to fit (give --fit or --preset)");
  if (problem.recordings.empty()) throw ArgumentError("calibrate: no recordings");
  validateParameters(problem.study, problem.origin, problem.parameters);
  Evaluator evaluator(problem.study, problem.origin, problem.recordings, problem.parameters, model, options);
  const auto& specs = problem.parameters;
  const int n = static_cast<int>(specs.size());

  CalibrationResult result;
  const std::vector<double> initial = currentValues(problem.study, specs);
  const Evaluation& start_eval = evaluator.at(initial);
  result.initial_residuals = start_eval.residuals;
  result.initial_chi2 = start_eval.chi2;
  result.initial_runs = start_eval.runs;

  std::vector<double> initial_x;
  for (int i = 0; i < n; ++i) initial_x.push_back(specs[i].toUnit(initial[i]));
  Search search(evaluator, options, n, begin);
  std::vector<LocalMinimum> found;
  for (int s = 0; s < std::max(1, options.starts); ++s) found.push_back(search.run(s, startPoint(s, initial_x)));
  const LocalMinimum best = *std::min_element(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.chi2 < b.chi2; });

  const UnitSigmas unit = unitSigmas(evaluator, best.x, options, result.curvature_eigenvalues);
  const std::vector<double>& sigma = unit.sigma;
  const std::vector<double> best_values = valuesOf(specs, best.x);
  for (int i = 0; i < n; ++i) {
    FittedParameter p;
    p.spec = specs[i];
    p.initial = initial[i];
    p.best = best_values[i];
    const double sd = toFileSigma(specs[i], best_values[i], sigma[i]);
    p.identified = std::isfinite(sigma[i]) && sigma[i] <= options.unidentified_fraction &&
                   sd <= options.unidentified_relative * std::abs(best_values[i]);
    p.std_dev = std::isfinite(sd) ? sd : std::numeric_limits<double>::infinity();
    if (p.identified) p.value = best_values[i];
    p.model_form_shift = toFileSigma(specs[i], best_values[i], unit.model_form[i]);
    result.parameters.push_back(p);
  }
  result.minima = distinctMinima(found, best, sigma, specs, options.noise_chi2);
  const Evaluation& fit = evaluator.at(best_values);
  result.residuals = fit.residuals;
  result.chi2 = fit.chi2;
  result.calibrated_runs = fit.runs;
  result.calibrated_study = withValues(problem.study, specs, best_values);
  result.measured = problem.recordings;
  result.evaluations = evaluator.evaluations();
  result.model_runs = evaluator.modelRuns();
  result.cache_hits = evaluator.cacheHits();
  result.failed_runs = evaluator.failedRuns();
  result.wall_time_s = std::chrono::duration<double>(Clock::now() - begin).count();
  return result;
}

std::vector<Residual> predict(const nlohmann::ordered_json& study, const std::string& origin, const std::vector<analysis::Recording>& recordings,
                              Model& model, const CalibrationOptions& options, std::vector<analysis::Recording>* runs) {
  if (recordings.empty()) throw ArgumentError("predict: no recordings");
  Evaluator evaluator(study, origin, recordings, {}, model, options);
  const Evaluation& e = evaluator.at({});
  if (runs) *runs = e.runs;
  return e.residuals;
}

StagedCalibration calibrateStages(const nlohmann::ordered_json& study, const std::string& origin, const std::vector<analysis::Recording>& recordings,
                                  const std::vector<Stage>& stages, Model& model, const CalibrationOptions& options) {
  StagedCalibration out;
  out.stages = stages;
  out.calibrated_study = study;
  for (const Stage& stage : stages) {
    CalibrationProblem problem{out.calibrated_study, origin, {}, stage.parameters};
    for (const auto& r : recordings)
      if (stage.cases.empty() || std::find(stage.cases.begin(), stage.cases.end(), r.key) != stage.cases.end()) problem.recordings.push_back(r);
    out.results.push_back(calibrate(problem, model, options));
    out.calibrated_study = out.results.back().calibrated_study;
  }
  return out;
}

}  // namespace demfem::campaign
