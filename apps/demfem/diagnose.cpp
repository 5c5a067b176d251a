// demfem diagnose: what the simulation gets wrong against recordings, the most likely cause from
// the catalogue, the model extended by it and the held-out gain (docs/diagnosis.md).
#include "commands.hpp"
#include "fit_options.hpp"

#include "demfem/campaign/diagnose.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>

namespace demfem::cli {
namespace {

struct DiagnoseOptions {
  FitOptions fit;
  campaign::DiagnosisSettings settings;
  std::vector<std::string> baseline_fit;
  std::vector<std::string> model_form;  // [QUANTITY=]PERCENT
  bool x_tolerance_given = false;
  bool no_pairs = false;
  double retired_min_error_percent = 0, retired_min_delta_bic = 0;  // accepted, without effect (docs/diagnosis.md)
};

void run(DiagnoseOptions& o, const std::string& json_target) {
  for (const auto& f : o.baseline_fit) o.settings.baseline_fit.push_back(campaign::parseParameterSpec(f));
  o.settings.pairs = !o.no_pairs;
  for (const auto& f : o.model_form) {
    const auto eq = f.find('=');
    const std::string quantity = eq == std::string::npos ? "" : f.substr(0, eq);
    if (!quantity.empty() && !std::count(campaign::quantityNames().begin(), campaign::quantityNames().end(), quantity))
      throw campaign::ArgumentError("--model-form-percent " + f + ": '" + quantity + "' is not a quantity");
    try {
      const double percent = std::stod(f.substr(eq == std::string::npos ? 0 : eq + 1));
      if (!(percent >= 0)) throw std::invalid_argument("negative");
      if (quantity.empty()) o.settings.model_form_percent.clear();
      o.settings.model_form_percent[quantity] = percent;
    } catch (const std::logic_error&) {
      throw campaign::ArgumentError("--model-form-percent " + f + ": not [QUANTITY=]PERCENT with PERCENT >= 0");
    }
  }
  if (!o.settings.model_form_percent.count("")) o.settings.model_form_percent[""] = 0.3;
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
  std::string named;
  for (const std::string& id : d.causes) named += (named.empty() ? " " : "+") + id;
  std::printf("verdict: %s%s\n", campaign::verdictText(d.verdict).c_str(), named.c_str());
  std::printf("reason: %s\n", d.reason.c_str());
  std::printf("  %-40s ln Z %.4g (probability %.3g)\n", d.baseline.id().c_str(), d.baseline.log_evidence, d.baseline.probability);
  for (const auto& m : d.models)
    std::printf("  %-40s ln Z %.4g (probability %.3g, ln B %.3g, %d significant, held-out %.3g %% -> %.3g %%, gain %.3g %%, %s)\n",
                m.id().c_str(), m.log_evidence, m.probability, m.ln_bayes_factor, m.significant, m.error_before_percent, m.error_after_percent,
                m.gain_percent, m.split.c_str());
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
  cmd->add_option("--baseline-fit", o->baseline_fit,
                  "Calibrated baseline parameter PATH=LO:HI[:log] (repeatable; default: the domain's preset, docs/diagnosis.md)");
  cmd->add_option("--model-form-percent", o->model_form,
                  "Model-form tolerance [QUANTITY=]PERCENT (repeatable, in order: a bare PERCENT sets every quantity; default 1.5 for step_force_N, 0.3 for the others)");
  cmd->add_option("--significance-level", s.significance_level, "Family-wise level of the residual test (Holm)")
      ->check(CLI::Range(1e-12, 0.5))
      ->capture_default_str();
  cmd->add_option("--min-ln-bayes-factor", s.min_ln_bayes_factor, "ln Bayes factor over the calibrated baseline a named model must reach")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--min-gain-percent", s.min_gain_percent, "Held-out chi2 cut a named model must reach, % (where a split identifies it)")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  cmd->add_option("--min-held-out-folds", s.min_held_out_folds, "Held-out cases a named model must predict (where a split identifies it)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_flag("--no-pairs", o->no_pairs, "Do not try two causes at once");
  cmd->add_flag("--all-pairs", s.all_pairs, "Pair the best single causes with every cause, not only those whose single fit has ln B > 0");
  cmd->add_option("--min-error-percent", o->retired_min_error_percent, "Retired (the residual test replaces it); accepted without effect");
  cmd->add_option("--min-delta-bic", o->retired_min_delta_bic, "Retired (the Bayes factor replaces it); accepted without effect");
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
