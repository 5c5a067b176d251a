// demfem diagnose: what the simulation gets wrong against recordings, the most likely cause from
// the catalogue, the model extended by it and the held-out gain (docs/diagnosis.md).
#include "commands.hpp"
#include "fit_options.hpp"

#include "demfem/campaign/diagnose.hpp"

#include <chrono>
#include <cstdio>

namespace demfem::cli {
namespace {

struct DiagnoseOptions {
  FitOptions fit;
  campaign::DiagnosisSettings settings;
  bool x_tolerance_given = false;
};

void run(DiagnoseOptions& o, const std::string& json_target) {
  const FitInputs in = readFitInputs(o.fit);
  configureFit(o.settings.calibration, o.fit, in.study, o.x_tolerance_given);
  const auto start = std::chrono::steady_clock::now();
  if (!o.fit.quiet)
    o.settings.on_stage = [start](const std::string& stage) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::fprintf(stderr, "diagnose: %s (%.0f s elapsed)\n", stage.c_str(), elapsed);
    };
  const auto model = campaign::makeModel(in.study, o.fit.soil.force, o.fit.soil.shared_packing, o.fit.soil.allow_unsettled_soil);
  const campaign::Diagnosis d = campaign::diagnose(in.study_json, o.fit.study_file, in.recordings, *model, o.settings);

  const auto dir = writeStaged(o.fit.analysis, [&](analysis::StagedOutput& out, const analysis::GnuplotRenderer* renderer) {
    campaign::writeDiagnosis(d, o.settings, out, renderer);
  });
  const std::string extended = (dir / "extended_study.json").string();
  writeJson(json_target, campaign::toJson(d, o.settings, extended));
  if (json_target == "-") return;
  std::printf("verdict: %s\n", d.cause ? ("cause " + *d.cause).c_str() : "no significant discrepancy");
  std::printf("reason: %s\n", d.reason.c_str());
  for (const auto& r : d.ranking)
    if (r.fitted)
      std::printf("  %-18s error %.3g %% -> %.3g %% (gain %.3g %%, delta BIC %.4g, %s)\n", r.id.c_str(), r.error_before_percent,
                  r.error_after_percent, r.gain_percent, r.delta_bic, r.split.c_str());
    else
      std::printf("  %-18s not fitted: signature absent\n", r.id.c_str());
  std::printf("extended study: %s\nreport: %s\n", extended.c_str(), (dir / "report.md").c_str());
}

}  // namespace

void addDiagnoseCommand(CLI::App& app) {
  auto o = std::make_shared<DiagnoseOptions>();
  o->fit.analysis.out_dir = "diagnosis";
  auto& s = o->settings;
  auto* cmd = app.add_subcommand("diagnose",
                                 "Say what the simulation gets wrong against recordings, name the most likely cause, fit the "
                                 "extended model and measure the gain on held-out cases");
  addFitInputs(*cmd, o->fit);
  cmd->add_option("--cause", s.causes, "Consider only this cause (repeatable; default: every cause of the recordings' kind)");
  cmd->add_option("--min-error-percent", s.min_error_percent, "Baseline error below which nothing is named")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--min-gain-percent", s.min_gain_percent, "Held-out error cut a cause must reach")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  cmd->add_option("--min-delta-bic", s.min_delta_bic, "BIC drop a cause must reach")->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd->add_option("--min-held-out-folds", s.min_held_out_folds, "Held-out cases the named cause must predict")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  addOptimiserOptions(*cmd, s.calibration, "Optimiser starts per fit");
  auto* x_tolerance = cmd->add_option("--x-tolerance", s.calibration.x_tolerance,
                                      "Optimiser tolerance, as a fraction of each parameter's bounds (soil: "
                                      "the noisy-objective step, docs/calibration.md)")
                          ->check(CLI::Range(1e-9, 0.1))
                          ->capture_default_str();
  std::string& json_target = addFitOutputs(*cmd, o->fit);
  cmd->callback([o, &json_target, x_tolerance] {
    o->x_tolerance_given = x_tolerance->count() > 0;
    runFit([&] { run(*o, json_target); });
  });
}

}  // namespace demfem::cli
