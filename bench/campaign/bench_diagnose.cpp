// Diagnosis benchmark (docs/diagnosis.md, section Cost): the wall and processor time of
// - a weight-drop diagnosis of the paper's PMMA tool (0.5 and 1 kg, two repeats each) on recordings
//   the project's modal model made with a compliant clamp (k_theta = --clamp-ei-l times the free
//   part's EI/L; --force-gain G: and a load cell reading G times the force, two causes at once) and
//   DAQ noise, every cause of the catalogue fitted, and the pairs when a single cause leaves a
//   significant residual (default);
// - with --soil-bin: a soil diagnosis of the small bin (tests/campaign/liggghts_layered_bin.hpp:
//   about 2,570 particles, 200 mm stroke, depths 20, 40, 55 mm) on recordings LIGGGHTS itself made
//   from the deck kept with the tests, the hidden effect the two layers (friction 0.2 above, 0.9
//   below; --uniform-friction F: one layer at F, the null case), diagnosed with the single-layer
//   built-in study at --study-friction (default: the deck's top layer, 0.2; with
//   --uniform-friction: F).
// Prints a table per model (the calibrated baseline, each cause, the pairs tried); --json writes the same.
#include "bench_timing.hpp"
#include "demfem/campaign/diagnose.hpp"
#include "demfem/cli/cli_support.hpp"
#include "layered_soil_study.hpp"
#include "truth_recordings.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>

namespace {

namespace fs = std::filesystem;
using namespace demfem;
using bench::Clock;

// EI / L of the tool's free part (below the clamp), N m/rad.
double freePartEiOverL(const nlohmann::ordered_json& tool) {
  const double E = tool["fem"]["E_Pa"], W = tool["geometry"]["width_mm"], T = tool["geometry"]["thickness_mm"];
  const double L = tool["geometry"]["length_mm"].get<double>() - tool["constraints"]["clamp_length_mm"].get<double>();
  return E * (W * 1e-3) * std::pow(T * 1e-3, 3) / 12 / (L * 1e-3);
}

struct SoilOptions {
  bool ci_bin = false;
  std::optional<double> uniform_friction, study_friction;
  int seeds = 3, jobs = 2, model_seeds = 1, max_evaluations = 8;
  std::string out = "bench-diagnose-soil", recordings;
};

// The models' table (printed) and JSON, the calibrated baseline first; the sum of their model runs.
nlohmann::json modelsTable(const campaign::Diagnosis& d, int& runs, std::FILE* table) {
  std::fprintf(table, "%-44s %8s %10s %14s %14s %10s %12s\n", "model", "runs", "wall (s)", "before (%)", "after (%)", "ln B", "probability");
  nlohmann::json models = nlohmann::json::array();
  runs = 0;
  std::vector<const campaign::ModelFit*> all{&d.baseline};
  for (const auto& m : d.models) all.push_back(&m);
  for (const campaign::ModelFit* m : all) {
    runs += m->model_runs;
    std::fprintf(table, "%-44s %8d %10.2f %14.2f %14.2f %10.1f %12.3g\n", m->id().c_str(), m->model_runs, m->wall_time_s, m->error_before_percent,
                 m->error_after_percent, m->ln_bayes_factor, m->probability);
    models.push_back({{"id", m->id()},
                      {"model_runs", m->model_runs},
                      {"wall_s", m->wall_time_s},
                      {"error_before_percent", m->error_before_percent},
                      {"error_after_percent", m->error_after_percent},
                      {"ln_bayes_factor", m->ln_bayes_factor},
                      {"probability", m->probability}});
  }
  return models;
}

// "cause a+b", "no significant discrepancy" or "unexplained discrepancy".
std::string verdictOf(const campaign::Diagnosis& d) {
  std::string text = campaign::verdictText(d.verdict);
  for (std::size_t i = 0; i < d.causes.size(); ++i) text += (i ? "+" : " ") + d.causes[i];
  return text;
}

nlohmann::json weightDrop(const std::string& study_file, double clamp_ei_l, double force_gain, int jobs, std::FILE* table) {
  const nlohmann::ordered_json study = cli::readJsonFile(study_file);
  nlohmann::ordered_json truth = study;
  const double k_true = clamp_ei_l * freePartEiOverL(study["tools"][0]);
  truth["tools"][0]["constraints"]["clamp_rotational_stiffness_Nm_per_rad"] = k_true;
  if (force_gain != 1) truth["tools"][0]["sensors"]["force_gain"] = force_gain;
  const fs::path dir = fs::temp_directory_path() / ("demfem-bench-diagnose-" + std::to_string(getpid()));
  fs::create_directories(dir / "recordings");
  std::fprintf(stderr, "writing the recordings (k_theta = %.4g N m/rad)\n", k_true);
  auto t = Clock::now();
  bench::writeTruth(truth, study_file, dir / "recordings");
  const double recordings_s = bench::secondsSince(t);
  const auto recordings = analysis::readRecordings({dir / "recordings"});

  campaign::DiagnosisSettings settings;
  settings.calibration.jobs = jobs;
  settings.calibration.kind = campaign::ObjectiveKind::Smooth;
  settings.calibration.cache_dir = dir / "runs";
  const auto start = Clock::now();
  settings.on_stage = [start](const std::string& stage) { std::fprintf(stderr, "diagnose: %s (%.0f s elapsed)\n", stage.c_str(), bench::secondsSince(start)); };
  const auto model = campaign::makeModel(study::parseStudy(study.dump(), study_file));
  t = Clock::now();
  const double c0 = bench::cpuSeconds();
  const campaign::Diagnosis d = campaign::diagnose(study, study_file, recordings, *model, settings);
  const double wall_s = bench::secondsSince(t), cpu_s = bench::cpuSeconds() - c0;
  fs::remove_all(dir);

  int runs = 0;
  const nlohmann::json models = modelsTable(d, runs, table);
  std::fprintf(table, "%-44s %8d %10.2f   (processor %.1f s, recordings %.1f s)\n", "whole diagnosis", runs, wall_s, cpu_s, recordings_s);
  std::fprintf(table, "verdict: %s (%s)\n", verdictOf(d).c_str(), d.reason.c_str());
  return {{"study", study_file},
          {"clamp_true_Nm_per_rad", k_true},
          {"force_gain_true", force_gain},
          {"jobs", jobs},
          {"recordings_s", recordings_s},
          {"diagnosis_wall_s", wall_s},
          {"diagnosis_cpu_s", cpu_s},
          {"verdict", campaign::verdictText(d.verdict)},
          {"causes", d.causes},
          {"models", models}};
}

nlohmann::json soilBin(const SoilOptions& o, std::FILE* table) {
  campaign::test::LayeredBin bin = o.ci_bin ? campaign::test::LayeredBin{} : campaign::test::smallBin();
  bin.seeds = o.seeds, bin.jobs = o.jobs, bin.uniform_friction = o.uniform_friction;
  const fs::path out(o.out);
  fs::create_directories(out);
  if (!std::getenv("DEMFEM_SOIL_DIR") && ::setenv("DEMFEM_SOIL_DIR", (out / "soil").c_str(), 1) != 0)
    throw std::runtime_error("cannot set DEMFEM_SOIL_DIR to " + (out / "soil").string());
  const double load_before = bench::loadAverage();
  const auto start = Clock::now();
  const double cpu_start = bench::cpuSeconds();
  std::vector<fs::path> files;
  if (o.recordings.empty()) {
    std::fprintf(stderr, "LIGGGHTS: %d depositions, %zu drags\n", bin.seeds, bin.depths_mm.size() * static_cast<std::size_t>(bin.seeds));
    files = campaign::test::runLayeredBin(bin, out / "liggghts");
  } else {
    files.push_back(o.recordings);
  }
  const double liggghts_s = bench::secondsSince(start), liggghts_cpu_s = bench::cpuSeconds() - cpu_start;
  const auto recordings = analysis::readRecordings(files);

  campaign::DiagnosisSettings settings;
  const double window_begin_mm = o.ci_bin ? campaign::test::kCiBinWindowBeginMm : campaign::test::kSmallBinWindowBeginMm;
  settings.calibration = campaign::test::layeredSoilOptions(bin, window_begin_mm, o.max_evaluations, out / "runs", o.model_seeds);
  const auto t = Clock::now();
  settings.on_stage = [t](const std::string& stage) { std::fprintf(stderr, "diagnose: %s (%.0f s elapsed)\n", stage.c_str(), bench::secondsSince(t)); };
  const double cpu_t = bench::cpuSeconds();
  const std::optional<double> friction = o.study_friction ? o.study_friction : o.uniform_friction ? o.uniform_friction : std::optional(0.2);
  const auto d = campaign::test::diagnoseSingleLayer(bin, recordings, settings, campaign::test::singleLayerStudy(bin, friction));
  const double wall_s = bench::secondsSince(t), cpu_s = bench::cpuSeconds() - cpu_t;
  const double load_after = bench::loadAverage();

  int runs = 0;
  const nlohmann::json models = modelsTable(d, runs, table);
  std::fprintf(table, "error of the study as given %.2f %%\n", d.nominal_error_percent);
  std::fprintf(table, "verdict: %s (%s)\n", verdictOf(d).c_str(), d.reason.c_str());
  std::fprintf(table, "%-40s %12s %12s\n", "step", "wall (s)", "CPU (s)");
  std::fprintf(table, "%-40s %12.0f %12.0f\n", "LIGGGHTS fixture", liggghts_s, liggghts_cpu_s);
  std::fprintf(table, "%-40s %12.0f %12.0f   (%d model runs in the fits)\n", "diagnosis", wall_s, cpu_s, runs);
  std::fprintf(table, "load average (1 min): %.2f before, %.2f after\n", load_before, load_after);
  return {{"bin_mm", {bin.width_m * 1000, bin.length_m * 1000, bin.fill_m * 1000}},
          {"stroke_mm", bin.stroke_m * 1000},
          {"depths_mm", bin.depths_mm},
          {"liggghts_seeds", bin.seeds},
          {"uniform_friction", o.uniform_friction ? nlohmann::json(*o.uniform_friction) : nlohmann::json(nullptr)},
          {"study_friction", *friction},
          {"model_seeds", o.model_seeds},
          {"max_evaluations", o.max_evaluations},
          {"jobs", o.jobs},
          {"liggghts_wall_s", liggghts_s},
          {"liggghts_cpu_s", liggghts_cpu_s},
          {"diagnosis_wall_s", wall_s},
          {"diagnosis_cpu_s", cpu_s},
          {"fit_model_runs", runs},
          {"load_average_before", load_before},
          {"load_average_after", load_after},
          {"models", models},
          {"diagnosis", campaign::toJson(d, settings, "")}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-diagnose: cost of a diagnosis: the paper tool with compliant-clamp recordings, or (--soil-bin) the small soil bin against LIGGGHTS"};
  app.name("demfem-bench-diagnose");
  std::string study_file = std::string(DEMFEM_SOURCE_DIR) + "/studies/weight_drop_1kg.json";
  double clamp_ei_l = 3.0, force_gain = 1.0;
  int jobs = 2;
  bool soil_bin = false;
  SoilOptions soil;
  app.add_option("--study", study_file, "weight-drop study of the tool")->check(CLI::ExistingFile)->capture_default_str();
  app.add_option("--clamp-ei-l", clamp_ei_l, "the recordings' clamp spring in units of EI/L")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--force-gain", force_gain, "the recordings' load-cell gain besides the clamp spring (not 1: two causes, the pairs run)")
      ->check(CLI::Range(0.7, 1.4))
      ->capture_default_str();
  app.add_option("--jobs", jobs, "cases run concurrently (with --soil-bin also LIGGGHTS processes)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_flag("--soil-bin", soil_bin, "The soil diagnosis of the small bin against LIGGGHTS instead of the weight drop");
  app.add_flag("--ci-bin", soil.ci_bin, "--soil-bin: the physics test's bin (100 x 140 mm, 40 mm stroke) instead of the small bin");
  app.add_option("--uniform-friction", soil.uniform_friction, "--soil-bin: one layer at this friction in the deck (the null case)")->check(CLI::Range(0.05, 1.5));
  app.add_option("--study-friction", soil.study_friction, "--soil-bin: friction of the single-layer study (default 0.2, or --uniform-friction)")
      ->check(CLI::Range(0.05, 1.5));
  app.add_option("--seeds", soil.seeds, "--soil-bin: LIGGGHTS deposition seeds (1..5)")->check(CLI::Range(1, 5))->capture_default_str();
  app.add_option("--model-seeds", soil.model_seeds, "--soil-bin: deposition seeds of every fit's runs")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--max-evaluations", soil.max_evaluations, "--soil-bin: objective evaluations per fit")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--out", soil.out, "--soil-bin: working directory (LIGGGHTS runs, soils, run cache)")->capture_default_str();
  app.add_option("--recordings", soil.recordings, "--soil-bin: the LIGGGHTS recordings of an earlier run in this directory")->check(CLI::ExistingDirectory);
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    soil.jobs = jobs;
    cli::writeJson(json_target, soil_bin ? soilBin(soil, cli::textStream(json_target))
                                         : weightDrop(study_file, clamp_ei_l, force_gain, jobs, cli::textStream(json_target)));
  });
  return cli::runApp(app, argc, argv);
}
