// Calibration benchmark (docs/calibration.md): the cost of a weight-drop evaluation before and after
// the first (modal re-use, campaign/model.hpp) and of the whole `--preset weight-drop` calibration of
// the paper's PMMA tool, on recordings the model itself made at known E and alpha with DAQ noise.
// Prints a table; --json writes the same numbers.
#include "demfem/campaign/calibration.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/weight_drop.hpp"
#include "truth_recordings.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;
using namespace demfem;
using bench::weight;

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-calibrate: cost of weight-drop evaluations and of the whole --preset weight-drop calibration"};
  app.name("demfem-bench-calibrate");
  std::string study_file = std::string(DEMFEM_SOURCE_DIR) + "/studies/weight_drop_0.5kg.json";
  int evaluations = 20, jobs = 2;
  app.add_option("--study", study_file, "weight-drop study of the tool")->check(CLI::ExistingFile)->capture_default_str();
  app.add_option("--evaluations", evaluations, "re-evaluations timed after the first")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--jobs", jobs, "cases run concurrently in the calibration")->check(CLI::PositiveNumber)->capture_default_str();
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    const nlohmann::ordered_json study = cli::readJsonFile(study_file);
    const double E0 = study["tools"][0]["fem"]["E_Pa"], alpha0 = study["tools"][0]["fem"]["alpha_s"];
    const double E_true = 1.08 * E0, alpha_true = 1.3 * alpha0;
    nlohmann::ordered_json truth = study;
    truth["tools"][0]["fem"]["E_Pa"] = E_true;
    truth["tools"][0]["fem"]["alpha_s"] = alpha_true;
    const fs::path dir = fs::temp_directory_path() / ("demfem-bench-calibrate-" + std::to_string(getpid()));
    fs::create_directories(dir);
    bench::writeTruth(truth, study_file, dir);
    const auto recordings = analysis::readRecordings({dir});
    fs::remove_all(dir);

    // First run of a case (reduction + modes) and re-runs at other E and alpha (modal recursion).
    campaign::WeightDropModel model;
    auto t = Clock::now();
    model.run(campaign::caseStudy(study, study_file, weight(0.5)), weight(0.5), {});
    const double first_s = secondsSince(t);
    t = Clock::now();
    model.run(campaign::caseStudy(study, study_file, weight(1.0)), weight(1.0), {});
    const double second_weight_s = secondsSince(t);
    t = Clock::now();
    for (int i = 0; i < evaluations; ++i) {
      nlohmann::ordered_json s = study;
      s["tools"][0]["fem"]["E_Pa"] = E0 * (0.8 + 0.02 * i);
      s["tools"][0]["fem"]["alpha_s"] = alpha0 * (0.5 + 0.05 * i);
      for (double mass : {0.5, 1.0}) model.run(campaign::caseStudy(s, study_file, weight(mass)), weight(mass), {});
    }
    const double rerun_s = secondsSince(t) / evaluations;  // both weights

    campaign::CalibrationOptions options;
    options.jobs = jobs;
    // The first two evaluations of the calibration: the first runs both weights' first runs
    // (reduction and modes) concurrently; progress is first reported after the second.
    double first_evaluations_s = 0;
    options.on_progress = [&](const campaign::CalibrationProgress& p) {
      if (p.evaluation == 2) first_evaluations_s = p.elapsed_s;
    };
    campaign::WeightDropModel fresh;
    t = Clock::now();
    const auto result = campaign::calibrateStages(study, study_file, recordings, campaign::weightDropPreset(study, recordings), fresh, options);
    const double calibration_s = secondsSince(t);
    const auto& r = result.results.front();
    const double per_evaluation_s = (calibration_s - first_evaluations_s) / std::max(1, r.evaluations - 2);
    const double E = r.parameters[0].value.value_or(NAN), alpha = r.parameters[1].value.value_or(NAN);

    std::FILE* const table = cli::textStream(json_target);
    std::fprintf(table, "%-52s %14s\n", "quantity", "value");
    std::fprintf(table, "%-52s %14.3f\n", "first run, 0.5 kg: reduction + modes (s)", first_s);
    std::fprintf(table, "%-52s %14.3f\n", "first run, 1 kg: modes (s)", second_weight_s);
    std::fprintf(table, "%-52s %14.4f\n", "re-evaluation, both weights, model only (s)", rerun_s);
    std::fprintf(table, "%-52s %14.3f\n", "first two evaluations in the calibration (s)", first_evaluations_s);
    std::fprintf(table, "%-52s %14.4f\n", "later objective evaluation in the calibration (s)", per_evaluation_s);
    std::fprintf(table, "%-52s %14.2f\n", "whole calibration, --preset weight-drop (s)", calibration_s);
    std::fprintf(table, "%-52s %14d\n", "objective evaluations", r.evaluations);
    std::fprintf(table, "%-52s %14d\n", "model runs", r.model_runs);
    std::fprintf(table, "%-52s %14.4f\n", "E error (%)", 100 * (E / E_true - 1));
    std::fprintf(table, "%-52s %14.4f\n", "alpha error (%)", 100 * (alpha / alpha_true - 1));
    std::fprintf(table, "%-52s %14.4g\n", "E std dev (%)", 100 * r.parameters[0].std_dev / E);
    std::fprintf(table, "%-52s %14.4g\n", "alpha std dev (%)", 100 * r.parameters[1].std_dev / alpha);
    cli::writeJson(json_target, {{"study", study_file},
                                 {"first_run_s", first_s},
                                 {"second_weight_first_run_s", second_weight_s},
                                 {"reevaluation_both_weights_s", rerun_s},
                                 {"first_two_evaluations_s", first_evaluations_s},
                                 {"objective_evaluation_s", per_evaluation_s},
                                 {"calibration_s", calibration_s},
                                 {"evaluations", r.evaluations},
                                 {"model_runs", r.model_runs},
                                 {"jobs", jobs},
                                 {"E_true_Pa", E_true},
                                 {"E_fitted_Pa", E},
                                 {"alpha_true_s", alpha_true},
                                 {"alpha_fitted_s", alpha},
                                 {"E_std_dev_Pa", r.parameters[0].std_dev},
                                 {"alpha_std_dev_s", r.parameters[1].std_dev}});
  });
  return cli::runApp(app, argc, argv);
}
