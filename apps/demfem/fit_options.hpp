// The option set shared by `demfem calibrate` and `demfem diagnose` (calibrate.cpp, diagnose.cpp;
// docs/calibration.md, docs/diagnosis.md): the study and its recordings, the optimiser's budget, the
// soil-bin model, the analysis settings, progress and the --json target; the objective both
// commands configure from them, the stop request on SIGINT/SIGTERM, and the campaign library's
// errors turned into the CLI's (exit codes 2 and 130).
#pragma once

#include "analysis_options.hpp"
#include "soil_model_options.hpp"

#include "demfem/campaign/calibration.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/cli/progress.hpp"

#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace demfem::cli {

struct FitOptions {
  AnalysisOptions analysis;
  std::string study_file;
  std::vector<std::string> recordings;
  SoilModelOptions soil;
  bool quiet = false;
};

// The positional study and recordings.
inline void addFitInputs(CLI::App& cmd, FitOptions& o) {
  cmd.add_option("study", o.study_file, "Study file of one case (weight-drop, coupled or dem-only)")->required()->check(CLI::ExistingFile);
  cmd.add_option("recordings", o.recordings, "Measured recordings or directories of recordings")->required();
}

// --starts (help text `starts_help`), --max-evaluations and --jobs.
inline void addOptimiserOptions(CLI::App& cmd, campaign::CalibrationOptions& c, const std::string& starts_help) {
  cmd.add_option("--starts", c.starts, starts_help)->check(CLI::PositiveNumber)->capture_default_str();
  cmd.add_option("--max-evaluations", c.max_evaluations, "Objective evaluations per start")->check(CLI::PositiveNumber)->capture_default_str();
  cmd.add_option("--jobs", c.jobs, "Cases run concurrently")->check(CLI::PositiveNumber)->capture_default_str();
}

// The soil-bin model options, --quiet, the analysis options and --json (its target returned).
inline std::string& addFitOutputs(CLI::App& cmd, FitOptions& o) {
  addSoilModelOptions(cmd, o.soil);
  cmd.add_flag("--quiet", o.quiet, "No progress on stderr");
  addAnalysisOptions(cmd, o.analysis);
  return addJsonOption(cmd);
}

struct FitInputs {
  std::shared_ptr<const OutputClaim> output;  // the output directory, claimed before the first model run
  study::Study study;
  nlohmann::ordered_json study_json;  // the study file as written (the fits edit it by JSON pointer)
  std::vector<analysis::Recording> recordings;
};

// Checks the analysis options, loads the study (a clear message for an invalid one before anything
// else) and reads the recordings. Throws InputError, study::StudyError or analysis::InputError.
inline FitInputs readFitInputs(FitOptions& o) {
  finishAnalysisOptions(o.analysis);
  FitInputs in{nullptr, loadCheckedStudy(o.study_file), {}, {}};
  in.output = std::make_shared<const OutputClaim>(o.analysis.out_dir);
  std::ifstream file(o.study_file);
  in.study_json = nlohmann::ordered_json::parse(file);
  in.recordings = analysis::readRecordings(std::vector<std::filesystem::path>(o.recordings.begin(), o.recordings.end()));
  return in;
}

inline std::atomic<bool>& fitStopFlag() {
  static std::atomic<bool> stop{false};
  return stop;
}
extern "C" inline void onFitStopSignal(int) { fitStopFlag() = true; }

// The objective of `study` from the options: analysis settings, soil deformation (a deformable tool
// that is coupled), smooth (weight drop) or noisy (soil) objective with the noisy steps unless the
// x tolerance was given, the soil model's stroke and seeds, the run cache under OUT/runs, and a stop
// request on SIGINT/SIGTERM.
inline void configureFit(campaign::CalibrationOptions& c, const FitOptions& o, const study::Study& study, bool x_tolerance_given) {
  c.objective.analysis = o.analysis.settings;
  c.objective.soil_deformation = study.kind != study::StudyKind::DemOnly && study.tools.front().fem.deformable;
  c.kind = study.kind == study::StudyKind::WeightDrop ? campaign::ObjectiveKind::Smooth : campaign::ObjectiveKind::Noisy;
  if (c.kind == campaign::ObjectiveKind::Noisy && !x_tolerance_given) campaign::useNoisySteps(c);
  c.stroke_ends_with_window = !o.soil.full_stroke;
  c.model_seeds = o.soil.model_seeds;
  c.cache_dir = std::filesystem::path(o.analysis.out_dir) / "runs";
  c.on_deposit = depositionProgress(!o.quiet);
  std::signal(SIGINT, onFitStopSignal);
  std::signal(SIGTERM, onFitStopSignal);
  c.stop_requested = [] { return fitStopFlag().load(); };
  useSoilDirectory(o.soil, c.cache_dir);
}

// Runs `body` with the analysis and campaign errors mapped to the CLI's.
inline void runFit(const std::function<void()>& body) {
  try {
    runAnalysis(body);
  } catch (const campaign::ArgumentError& e) {
    throw InputError(e.what());
  } catch (const campaign::Interrupted& e) {
    throw Interrupted(e.what());
  }
}

}  // namespace demfem::cli
