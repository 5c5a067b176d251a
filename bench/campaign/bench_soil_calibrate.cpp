// Soil calibration and diagnosis benchmark (docs/calibration.md, "Soil against LIGGGHTS"): the
// layered-bin fixture of the physics test (tests/campaign/liggghts_layered_bin.hpp, LIGGGHTS itself
// from the deck kept with the test), by default the small bin of the issue (about 2,570 particles,
// 200 mm stroke, depths 20, 40, 55 mm, five seeds); then `--preset layered-soil`, the single-layer
// fit at the shallowest depth and the diagnosis of the single-layer study, each timed. Prints a
// table; --json writes the same numbers.
#include "layered_soil_study.hpp"

#include "demfem/cli/cli_support.hpp"

#include <cstdio>
#include <cstdlib>

namespace {

namespace fs = std::filesystem;
using namespace demfem;
using Clock = std::chrono::steady_clock;

nlohmann::json parametersJson(const campaign::StagedCalibration& c) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& r : c.results)
    for (const auto& p : r.parameters)
      out.push_back({{"pointer", p.spec.pointer}, {"value", p.best}, {"std_dev", p.std_dev}, {"identified", p.identified},
                     {"evaluations", r.evaluations}, {"model_runs", r.model_runs}, {"wall_time_s", r.wall_time_s}});
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-soil-calibrate: soil calibration and diagnosis of a two-layer bin against LIGGGHTS itself"};
  app.name("demfem-bench-soil-calibrate");
  campaign::test::LayeredBin bin;
  bool ci_bin = false, no_diagnosis = false, diagnosis_only = false;
  int diagnosis_seeds = 1, diagnosis_evaluations = 8;
  int max_evaluations = 12, model_seeds = 3;
  double window_begin_mm = 50, diagnosis_friction = 0.2;
  std::string out_dir = "bench-soil", recordings_dir;
  bin.seeds = 5;
  app.add_flag("--ci-bin", ci_bin, "The physics test's bin (100 x 140 mm, 40 mm stroke, 3 seeds) instead of the small bin (100 x 330 mm, 200 mm stroke)");
  app.add_option("--seeds", bin.seeds, "LIGGGHTS deposition seeds (1..5)")->check(CLI::Range(1, 5))->capture_default_str();
  app.add_option("--jobs", bin.jobs, "Runs at once (LIGGGHTS processes; cases of one evaluation)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--max-evaluations", max_evaluations, "Objective evaluations per fit")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--model-seeds", model_seeds, "Deposition seeds each built-in case runs at")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--window-begin-mm", window_begin_mm, "Start of the statistics window (it ends with the stroke)")->capture_default_str();
  app.add_option("--out", out_dir, "Working directory (LIGGGHTS runs, soils, run cache)")->capture_default_str();
  app.add_option("--recordings", recordings_dir, "Use the LIGGGHTS recordings of an earlier run in this directory instead of running LIGGGHTS")
      ->check(CLI::ExistingDirectory);
  app.add_flag("--no-diagnosis", no_diagnosis, "Skip the diagnosis");
  app.add_flag("--diagnosis-only", diagnosis_only,
               "Only the diagnosis of the single-layer study at --diagnosis-friction (no calibration; otherwise the diagnosis starts from the "
               "single layer fitted at the shallowest depth)");
  app.add_option("--diagnosis-friction", diagnosis_friction, "Particle friction of the single-layer study of --diagnosis-only (the deck's top layer: 0.2)")
      ->check(CLI::Range(0.05, 1.5))
      ->capture_default_str();
  app.add_option("--diagnosis-seeds", diagnosis_seeds, "Model seeds of the diagnosis' runs")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--diagnosis-evaluations", diagnosis_evaluations, "Objective evaluations per fit of the diagnosis")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    if (ci_bin) {
      bin.seeds = std::min(bin.seeds, 3);
      window_begin_mm = 10;
    } else {
      bin.length_m = 0.33, bin.stroke_m = 0.2;
    }
    const fs::path out(out_dir);
    fs::create_directories(out);
    if (!std::getenv("DEMFEM_SOIL_DIR")) ::setenv("DEMFEM_SOIL_DIR", (out / "soil").c_str(), 1);
    auto t = Clock::now();
    double liggghts_s = 0;
    std::vector<fs::path> files;
    if (recordings_dir.empty()) {
      std::fprintf(stderr, "LIGGGHTS: %d depositions, %zu drags\n", bin.seeds, bin.depths_mm.size() * static_cast<std::size_t>(bin.seeds));
      files = campaign::test::runLayeredBin(bin, out / "liggghts");
      liggghts_s = campaign::test::detail::secondsSince(t);
    } else {
      files.push_back(recordings_dir);
    }
    const auto recordings = analysis::readRecordings(files);
    const auto options = campaign::test::layeredSoilOptions(bin, window_begin_mm, max_evaluations, out / "runs", model_seeds);
    campaign::DiagnosisSettings diagnosis;
    diagnosis.calibration = options;
    diagnosis.calibration.model_seeds = diagnosis_seeds;
    diagnosis.calibration.max_evaluations = diagnosis_evaluations;
    diagnosis.on_stage = [start = Clock::now()](const std::string& stage) {
      std::fprintf(stderr, "diagnose: %s (%.0f s elapsed)\n", stage.c_str(), campaign::test::detail::secondsSince(start));
    };
    if (diagnosis_only) {
      t = Clock::now();
      const auto d = campaign::test::diagnoseSingleLayer(bin, recordings, diagnosis, campaign::test::singleLayerStudy(bin, diagnosis_friction));
      std::printf("diagnosis: %s (%s), %.0f s\n", d.cause ? d.cause->c_str() : "no significant discrepancy", d.reason.c_str(),
                  campaign::test::detail::secondsSince(t));
      cli::writeJson(json_target, {{"diagnosis", campaign::toJson(d, diagnosis, "")},
                                   {"diagnosis_wall_s", campaign::test::detail::secondsSince(t)},
                                   {"liggghts_wall_s", liggghts_s}});
      return;
    }
    std::fprintf(stderr, "calibrating (at most %d evaluations per fit)\n", max_evaluations);
    const auto o = campaign::test::runLayeredSoil(bin, recordings, options, no_diagnosis ? nullptr : &diagnosis);

    nlohmann::json depths = nlohmann::json::array();
    std::printf("%-8s %20s %20s %20s\n", "depth", "LIGGGHTS draught (N)", "two layers (N)", "one layer (N)");
    const auto seedJson = [](const campaign::test::SeedMean& m) { return nlohmann::json{{"mean_N", m.mean_N}, {"sd_N", m.sd_N}, {"failed_runs", m.failed_runs}}; };
    for (const auto& d : o.depths) {
      std::printf("%5.0f mm %12.3f +- %5.3f %12.3f +- %5.3f %12.3f +- %5.3f\n", d.depth_mm, d.liggghts.mean_N, d.liggghts.sd_N, d.calibrated.mean_N,
                  d.calibrated.sd_N, d.single_layer.mean_N, d.single_layer.sd_N);
      depths.push_back({{"depth_mm", d.depth_mm}, {"liggghts", seedJson(d.liggghts)}, {"calibrated", seedJson(d.calibrated)},
                        {"single_layer", seedJson(d.single_layer)}});
    }
    std::printf("LIGGGHTS runs: %.0f s; layered-soil calibration + prediction: %.0f s; single layer: %.0f s\n", liggghts_s, o.layered_wall_s,
                o.single_wall_s);
    nlohmann::json doc = {{"seeds", bin.seeds},
                          {"stroke_mm", bin.stroke_m * 1000},
                          {"bin_mm", {bin.width_m * 1000, bin.length_m * 1000, bin.fill_m * 1000}},
                          {"window_begin_mm", window_begin_mm},
                          {"max_evaluations", max_evaluations},
                          {"model_seeds", model_seeds},
                          {"jobs", bin.jobs},
                          {"depths", depths},
                          {"liggghts_wall_s", liggghts_s},
                          {"layered_calibration_wall_s", o.layered_wall_s},
                          {"single_layer_wall_s", o.single_wall_s},
                          {"layered_parameters", parametersJson(o.layered)},
                          {"single_layer_parameters", parametersJson(o.single)}};
    if (o.diagnosis) {
      const auto& d = *o.diagnosis;
      std::printf("diagnosis: %s (%s), %.0f s\n", d.cause ? d.cause->c_str() : "no significant discrepancy", d.reason.c_str(), o.diagnosis_wall_s);
      doc["diagnosis"] = campaign::toJson(d, diagnosis, "");
      doc["diagnosis_wall_s"] = o.diagnosis_wall_s;
      doc["diagnosis_model_seeds"] = diagnosis_seeds;
    }
    cli::writeJson(json_target, doc);
  });
  return cli::runApp(app, argc, argv);
}
