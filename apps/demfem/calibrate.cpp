// demfem calibrate: fits study numbers (named by JSON pointer) to recordings with NLopt; presets for
// the paper's procedures (Section 2.10); calibrated study, report, plots (docs/calibration.md).
#include "analysis_options.hpp"
#include "commands.hpp"
#include "soil_model_options.hpp"

#include "demfem/campaign/calibration.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/cli/progress.hpp"

#include <atomic>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>

namespace demfem::cli {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void onStopSignal(int) { g_stop = true; }

struct CalibrateOptions {
  AnalysisOptions analysis;
  std::string study_file;
  std::vector<std::string> recordings;
  std::vector<std::string> fits;
  std::string preset;
  campaign::CalibrationOptions calibration;
  SoilModelOptions soil;
  bool quiet = false;
};

nlohmann::ordered_json readStudyJson(const std::string& file) {
  cli::loadCheckedStudy(file);  // a clear message for an invalid study before anything else
  std::ifstream in(file);
  return nlohmann::ordered_json::parse(in);
}

std::vector<campaign::Stage> stagesOf(const CalibrateOptions& o, const nlohmann::ordered_json& study,
                                      const std::vector<analysis::Recording>& recordings) {
  if (!o.preset.empty() && !o.fits.empty()) throw InputError("--preset and --fit: give one of them");
  if (o.preset == "weight-drop") return campaign::weightDropPreset(study, recordings);
  if (o.preset == "layered-soil") return campaign::layeredSoilPreset(study, o.study_file, recordings);
  if (o.fits.empty()) throw InputError("nothing to fit: give --fit PATH=LO:HI[:log] (repeatable) or --preset");
  campaign::Stage stage;
  stage.title = "fit of " + std::to_string(o.fits.size()) + " parameter(s)";
  for (const auto& f : o.fits) stage.parameters.push_back(campaign::parseParameterSpec(f));
  return {stage};
}

void run(CalibrateOptions& o, const std::string& json_target) {
  finishAnalysisOptions(o.analysis);
  const nlohmann::ordered_json study_json = readStudyJson(o.study_file);
  const study::Study study = cli::loadCheckedStudy(o.study_file);
  std::vector<std::filesystem::path> paths(o.recordings.begin(), o.recordings.end());
  const auto recordings = analysis::readRecordings(paths);
  const auto stages = stagesOf(o, study_json, recordings);
  auto& c = o.calibration;
  c.objective.analysis = o.analysis.settings;
  c.objective.soil_deformation = study.kind != study::StudyKind::DemOnly && study.tools.front().fem.deformable;
  c.kind = study.kind == study::StudyKind::WeightDrop ? campaign::ObjectiveKind::Smooth : campaign::ObjectiveKind::Noisy;
  if (c.kind == campaign::ObjectiveKind::Noisy) campaign::useNoisySteps(c);
  c.stroke_ends_with_window = !o.soil.full_stroke;
  c.model_seeds = o.soil.model_seeds;
  c.cache_dir = std::filesystem::path(o.analysis.out_dir) / "runs";
  Progress progress("calibrate", !o.quiet);
  c.on_progress = [&progress](const campaign::CalibrationProgress& p) {
    char detail[128];
    std::snprintf(detail, sizeof detail, "evaluation %d of at most %d, start %d/%d, best chi2 %.4g", p.evaluation, p.max_evaluations,
                  p.start, p.starts, p.best_chi2);
    progress.update(p.max_evaluations > 0 ? static_cast<double>(p.evaluation) / p.max_evaluations : 0.0, detail);
  };
  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);
  c.stop_requested = [] { return g_stop.load(); };
  useSoilDirectory(o.soil, c.cache_dir);
  const auto model = campaign::makeModel(study, o.soil.force, o.soil.shared_packing);
  const auto result = campaign::calibrateStages(study_json, o.study_file, recordings, stages, *model, c);
  progress.finish();

  analysis::StagedOutput out(o.analysis.out_dir);
  const analysis::GnuplotRenderer renderer(o.analysis.gnuplot);
  campaign::writeCalibration(result, c, out, o.analysis.no_plots ? nullptr : &renderer);
  out.commit();
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
  std::printf("calibrated study: %s\nreport: %s\n", (out.directory() / "calibrated_study.json").c_str(),
              (out.directory() / "report.md").c_str());
}

}  // namespace

void addCalibrateCommand(CLI::App& app) {
  auto o = std::make_shared<CalibrateOptions>();
  o->analysis.out_dir = "calibration";
  auto* cmd = app.add_subcommand("calibrate",
                                 "Fit study numbers to recordings (cases from the sidecars: mass_kg or depth_mm) with a bounded "
                                 "derivative-free optimiser; every model run is kept under OUT/runs");
  cmd->add_option("study", o->study_file, "Study file of one case (weight-drop, coupled or dem-only)")->required()->check(CLI::ExistingFile);
  cmd->add_option("recordings", o->recordings, "Measured recordings or directories of recordings")->required();
  cmd->add_option("--fit", o->fits, "Parameter PATH=LO:HI[:log], PATH a JSON pointer into the study (repeatable)");
  cmd->add_option("--preset", o->preset, "The paper's procedure: weight-drop (E, alpha) or layered-soil (friction per layer)")
      ->check(CLI::IsMember({"weight-drop", "layered-soil"}));
  cmd->add_option("--starts", o->calibration.starts, "Optimiser starts (the first at the study's values)")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--max-evaluations", o->calibration.max_evaluations, "Objective evaluations per start")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--jobs", o->calibration.jobs, "Cases run concurrently")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--relative-floor", o->calibration.objective.relative_floor, "Smallest scatter, relative to the measured value")
      ->check(CLI::Range(1e-9, 1.0))
      ->capture_default_str();
  addSoilModelOptions(*cmd, o->soil);
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  addAnalysisOptions(*cmd, o->analysis);
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([o, &json_target] {
    try {
      runAnalysis([&] { run(*o, json_target); });
    } catch (const campaign::ArgumentError& e) {
      throw InputError(e.what());
    } catch (const campaign::Interrupted& e) {
      throw Interrupted(e.what());
    }
  });
}

}  // namespace demfem::cli
