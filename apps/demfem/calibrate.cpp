// demfem calibrate: fits study numbers (named by JSON pointer) to recordings with NLopt; presets for
// the paper's procedures (Section 2.10); calibrated study, report, plots (docs/calibration.md).
#include "commands.hpp"
#include "fit_options.hpp"

#include "demfem/cli/progress.hpp"

#include <cstdio>
#include <iostream>

namespace demfem::cli {
namespace {

struct CalibrateOptions {
  FitOptions fit;
  std::vector<std::string> fits;
  std::string preset;
  campaign::CalibrationOptions calibration;
};

std::vector<campaign::Stage> stagesOf(const CalibrateOptions& o, const nlohmann::ordered_json& study,
                                      const std::vector<analysis::Recording>& recordings) {
  if (!o.preset.empty() && !o.fits.empty()) throw InputError("--preset and --fit: give one of them");
  if (o.preset == "weight-drop") return campaign::weightDropPreset(study, recordings);
  if (o.preset == "layered-soil") return campaign::layeredSoilPreset(study, o.fit.study_file, recordings);
  if (o.fits.empty()) throw InputError("nothing to fit: give --fit PATH=LO:HI[:log] (repeatable) or --preset");
  campaign::Stage stage;
  stage.title = "fit of " + std::to_string(o.fits.size()) + " parameter(s)";
  for (const auto& f : o.fits) stage.parameters.push_back(campaign::parseParameterSpec(f));
  return {stage};
}

void run(CalibrateOptions& o, const std::string& json_target) {
  const FitInputs in = readFitInputs(o.fit);
  const auto stages = stagesOf(o, in.study_json, in.recordings);
  auto& c = o.calibration;
  configureFit(c, o.fit, in.study, false);
  Progress progress("calibrate", !o.fit.quiet);
  c.on_progress = [&progress](const campaign::CalibrationProgress& p) {
    char detail[128];
    std::snprintf(detail, sizeof detail, "evaluation %d of at most %d, start %d/%d, best chi2 %.4g", p.evaluation, p.max_evaluations,
                  p.start, p.starts, p.best_chi2);
    progress.update(p.max_evaluations > 0 ? static_cast<double>(p.evaluation) / p.max_evaluations : 0.0, detail);
  };
  const auto model = campaign::makeModel(in.study, o.fit.soil.force, o.fit.soil.shared_packing, o.fit.soil.allow_unsettled_soil);
  const auto result = campaign::calibrateStages(in.study_json, o.fit.study_file, in.recordings, stages, *model, c);
  progress.finish();

  const auto dir = writeStaged(o.fit.analysis, [&](analysis::StagedOutput& out, const analysis::GnuplotRenderer* renderer) {
    campaign::writeCalibration(result, c, out, renderer);
  });
  writeJson(json_target, campaign::toJson(result, c));
  if (!textOnStdout(json_target)) return;
  for (const auto& r : result.results) {
    for (const auto& p : r.parameters) {
      if (p.value) std::printf("%s = %.6g +- %.2g\n", p.spec.pointer.c_str(), *p.value, p.std_dev);
      else std::printf("%s: unidentified by these recordings\n", p.spec.pointer.c_str());
    }
    std::printf("chi2 %.4g -> %.4g, %d model runs (%d from the cache), %.1f s\n", r.initial_chi2, r.chi2, r.model_runs, r.cache_hits,
                r.wall_time_s);
  }
  std::printf("calibrated study: %s\nreport: %s\n", (dir / "calibrated_study.json").c_str(), (dir / "report.md").c_str());
}

}  // namespace

void addCalibrateCommand(CLI::App& app) {
  auto o = std::make_shared<CalibrateOptions>();
  o->fit.analysis.out_dir = "calibration";
  auto* cmd = app.add_subcommand("calibrate",
                                 "Fit study numbers to recordings (cases from the sidecars: mass_kg or depth_mm) with a bounded "
                                 "derivative-free optimiser; every model run is kept under OUT/runs");
  addFitInputs(*cmd, o->fit);
  cmd->add_option("--fit", o->fits, "Parameter PATH=LO:HI[:log], PATH a JSON pointer into the study (repeatable)");
  cmd->add_option("--preset", o->preset, "The paper's procedure: weight-drop (E, alpha) or layered-soil (friction per layer)")
      ->check(CLI::IsMember({"weight-drop", "layered-soil"}));
  addOptimiserOptions(*cmd, o->calibration, "Optimiser starts (the first at the study's values)");
  cmd->add_option("--relative-floor", o->calibration.objective.relative_floor, "Smallest scatter, relative to the measured value")
      ->check(CLI::Range(1e-9, 1.0))
      ->capture_default_str();
  std::string& json_target = addFitOutputs(*cmd, o->fit);
  cmd->callback([o, &json_target] { runFit([&] { run(*o, json_target); }); });
}

}  // namespace demfem::cli
