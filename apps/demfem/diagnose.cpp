// demfem diagnose: what the simulation gets wrong against recordings, the most likely cause from
// the catalogue, the model extended by it and the held-out gain (docs/diagnosis.md).
#include "analysis_options.hpp"
#include "commands.hpp"
#include "soil_model_options.hpp"

#include "demfem/campaign/diagnose.hpp"
#include "demfem/cli/backend_registry.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>

namespace demfem::cli {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void onDiagnoseStop(int) { g_stop = true; }

struct DiagnoseOptions {
  AnalysisOptions analysis;
  std::string study_file;
  std::vector<std::string> recordings;
  campaign::DiagnosisSettings settings;
  SoilModelOptions soil;
  bool x_tolerance_given = false;
  bool quiet = false;
};

nlohmann::ordered_json readStudyJson(const std::string& file) {
  cli::loadCheckedStudy(file);  // a clear message for an invalid study before anything else
  std::ifstream in(file);
  return nlohmann::ordered_json::parse(in);
}

void run(DiagnoseOptions& o, const std::string& json_target) {
  finishAnalysisOptions(o.analysis);
  const nlohmann::ordered_json study_json = readStudyJson(o.study_file);
  const study::Study study = cli::loadCheckedStudy(o.study_file);
  const auto recordings = analysis::readRecordings(std::vector<std::filesystem::path>(o.recordings.begin(), o.recordings.end()));
  auto& c = o.settings.calibration;
  c.objective.analysis = o.analysis.settings;
  c.objective.soil_deformation = study.kind != study::StudyKind::DemOnly && study.tools.front().fem.deformable;
  c.kind = study.kind == study::StudyKind::WeightDrop ? campaign::ObjectiveKind::Smooth : campaign::ObjectiveKind::Noisy;
  if (c.kind == campaign::ObjectiveKind::Noisy && !o.x_tolerance_given) campaign::useNoisySteps(c);
  c.stroke_ends_with_window = !o.soil.full_stroke;
  c.model_seeds = o.soil.model_seeds;
  c.cache_dir = std::filesystem::path(o.analysis.out_dir) / "runs";
  const auto start = std::chrono::steady_clock::now();
  if (!o.quiet)
    o.settings.on_stage = [start](const std::string& stage) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::fprintf(stderr, "diagnose: %s (%.0f s elapsed)\n", stage.c_str(), elapsed);
    };
  std::signal(SIGINT, onDiagnoseStop);
  std::signal(SIGTERM, onDiagnoseStop);
  c.stop_requested = [] { return g_stop.load(); };
  useSoilDirectory(o.soil, c.cache_dir);
  const auto model = campaign::makeModel(study, o.soil.force, o.soil.shared_packing);
  const campaign::Diagnosis d = campaign::diagnose(study_json, o.study_file, recordings, *model, o.settings);

  analysis::StagedOutput out(o.analysis.out_dir);
  const analysis::GnuplotRenderer renderer(o.analysis.gnuplot);
  campaign::writeDiagnosis(d, o.settings, out, o.analysis.no_plots ? nullptr : &renderer);
  out.commit();
  const std::string extended = (out.directory() / "extended_study.json").string();
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
  std::printf("extended study: %s\nreport: %s\n", extended.c_str(), (out.directory() / "report.md").c_str());
}

}  // namespace

void addDiagnoseCommand(CLI::App& app) {
  auto o = std::make_shared<DiagnoseOptions>();
  o->analysis.out_dir = "diagnosis";
  auto& s = o->settings;
  auto* cmd = app.add_subcommand("diagnose",
                                 "Say what the simulation gets wrong against recordings, name the most likely cause, fit the "
                                 "extended model and measure the gain on held-out cases");
  cmd->add_option("study", o->study_file, "Study file of one case (weight-drop, coupled or dem-only)")->required()->check(CLI::ExistingFile);
  cmd->add_option("recordings", o->recordings, "Measured recordings or directories of recordings")->required();
  cmd->add_option("--cause", s.causes, "Consider only this cause (repeatable; default: every cause of the recordings' kind)");
  cmd->add_option("--min-error-percent", s.min_error_percent, "Baseline error below which nothing is named")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--min-gain-percent", s.min_gain_percent, "Held-out error cut a cause must reach")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  cmd->add_option("--min-delta-bic", s.min_delta_bic, "BIC drop a cause must reach")->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd->add_option("--starts", s.calibration.starts, "Optimiser starts per fit")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--max-evaluations", s.calibration.max_evaluations, "Objective evaluations per start")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  auto* x_tolerance = cmd->add_option("--x-tolerance", s.calibration.x_tolerance,
                                      "Optimiser tolerance, as a fraction of each parameter's bounds (soil: "
                                      "the noisy-objective step, docs/calibration.md)")
                          ->check(CLI::Range(1e-9, 0.1))
                          ->capture_default_str();
  cmd->add_option("--jobs", s.calibration.jobs, "Cases run concurrently")->check(CLI::PositiveNumber)->capture_default_str();
  addSoilModelOptions(*cmd, o->soil);
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  addAnalysisOptions(*cmd, o->analysis);
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([o, &json_target, x_tolerance] {
    o->x_tolerance_given = x_tolerance->count() > 0;
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
