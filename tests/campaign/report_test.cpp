// The reports of calibrate, diagnose and the paper campaign: every CSV table's cells equal the JSON
// document's values (both generated from one declaration of the table's columns), the numbers put
// in reach the JSON and the Markdown unchanged, absent values are null.
#include "demfem/adapter/output_files.hpp"
#include "demfem/analysis/synthetic.hpp"
#include "demfem/campaign/calibration.hpp"
#include "demfem/campaign/diagnose.hpp"
#include "demfem/campaign/paper_campaign.hpp"
#include "demfem/campaign/paper_report.hpp"
#include "support/csv_json.hpp"
#include "support/temp_dir.hpp"
#include "demfem/vtkio/vtk_files.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

using namespace demfem;
using namespace demfem::campaign;
using demfem::support::checkCsvMatchesJson;
using demfem::support::nestedRows;
using demfem::support::readText;
using demfem::support::TempDir;
namespace fs = std::filesystem;

namespace {

// Every piece of `expected` appears in `text`.
void checkContains(const std::string& text, const std::vector<std::string>& expected) {
  for (const std::string& piece : expected) CHECK_THAT(text, Catch::Contains(piece));
}

// Writes through a staged output into `dir` and commits it.
void writeStaged(const fs::path& dir, const std::function<void(analysis::StagedOutput&)>& write) {
  analysis::StagedOutput out(dir);
  write(out);
  out.commit();
}

analysis::CaseKey weight(double mass_kg) { return {analysis::CaseKind::CalibrationWeight, "PMMA", 0.0, mass_kg}; }
analysis::CaseKey soilBin(double depth_mm) { return {analysis::CaseKind::SoilBin, "PMMA", depth_mm, 0.0}; }

FittedParameter parameter(const std::string& pointer, double lo, double hi, bool log, double initial, std::optional<double> value, double std_dev) {
  FittedParameter p;
  p.spec.pointer = pointer, p.spec.lo = lo, p.spec.hi = hi, p.spec.log = log;
  p.initial = initial, p.value = value, p.std_dev = std_dev, p.identified = value.has_value();
  p.best = value.value_or(0.7 * hi);
  return p;
}

Residual residual(const analysis::CaseKey& key, const std::string& quantity, double measured, double simulated, double sigma) {
  return {key, quantity, measured, simulated, sigma, (simulated - measured) / sigma, false};
}

// Two stages: E and alpha from the weights (alpha unidentified, two distinct minima), then a
// friction from one soil-bin depth.
StagedCalibration twoStages() {
  StagedCalibration c;
  c.stages = {{"weights: E and alpha", {}, {weight(0.5), weight(1.0)}}, {"depth 30 mm: friction", {}, {soilBin(30)}}};
  CalibrationResult weights;
  weights.parameters = {parameter("/tools/0/fem/E_Pa", 1e9, 1.6e10, true, 4.06e9, 4.4987e9, 2.8e6),
                        parameter("/tools/0/fem/alpha_s", 1e-6, 1e-2, true, 5.5e-4, std::nullopt, std::numeric_limits<double>::infinity())};
  weights.initial_residuals = {residual(weight(0.5), "step_force_N", 2.45, 2.31, 0.01), residual(weight(1.0), "frequency_Hz", 3.1, 2.9, 0.02)};
  weights.residuals = {residual(weight(0.5), "step_force_N", 2.45, 2.449, 0.01), residual(weight(1.0), "frequency_Hz", 3.1, 3.102, 0.02)};
  weights.residuals[1].missing = true;
  weights.initial_chi2 = 296, weights.chi2 = 0.02;
  weights.minima = {{{4.4987e9, 1e-4}, 0.02}, {{4.51e9, 3e-3}, 0.5}};
  weights.evaluations = 112, weights.model_runs = 224, weights.cache_hits = 3, weights.wall_time_s = 41.4;
  CalibrationResult soil;
  soil.parameters = {parameter("/soil/interactions/0/static_friction", 0.05, 1.5, false, 0.5, 0.57, 0.04)};
  soil.initial_residuals = {residual(soilBin(30), "force_mean_N", 1.74, 2.2, 0.15)};
  soil.residuals = {residual(soilBin(30), "force_mean_N", 1.74, 1.98, 0.15)};
  soil.initial_chi2 = 9.4, soil.chi2 = 2.56;
  soil.minima = {{{0.57}, 2.56}};
  soil.evaluations = 8, soil.model_runs = 8, soil.failed_runs = 1, soil.wall_time_s = 1234.5;
  c.results = {weights, soil};
  return c;
}

ModelFit baselineModel() {
  ModelFit m;
  m.parameters = {parameter("/tools/0/fem/E_Pa", 3.69e9, 4.47e9, true, 4.06e9, 3.8e9, 1e7)};
  m.minima = 1, m.held_out_folds = 2, m.split = "leave one case out (2 folds)";
  m.chi2 = 2856, m.log_likelihood = -1428, m.log_occam = -5.1, m.log_evidence = -1433.1, m.probability = 0.0;
  m.significant = 4, m.model_runs = 40, m.wall_time_s = 0.8;
  return m;
}

ModelFit clampModel() {
  ModelFit m;
  m.causes = {"clamp_compliance"};
  m.parameters = {parameter("/tools/0/fem/E_Pa", 3.69e9, 4.47e9, true, 4.06e9, 4.07e9, 1e7),
                  parameter("/tools/0/constraints/clamp_rotational_stiffness_Nm_per_rad", 0.15, 1500, true, 150, 1.52, 0.03)};
  m.minima = 1, m.held_out_folds = 2, m.split = "leave one case out (2 folds)";
  m.error_before_percent = 17.2, m.error_after_percent = 0.15, m.noise_error_percent = 0.8, m.gain_percent = 95.3;
  m.held_out_chi2_before = 1080, m.held_out_chi2_after = 0.39, m.chi2_gain_percent = 99.3;
  m.chi2 = 12.5, m.log_likelihood = -6.25, m.log_occam = -8.0, m.log_evidence = -14.25, m.ln_bayes_factor = 1418.85, m.probability = 1.0;
  m.model_runs = 96, m.wall_time_s = 3.2;
  return m;
}

Diagnosis diagnosis() {
  Diagnosis d;
  analysis::WeightDropSignature light, heavy;
  light.key = weight(0.125), heavy.key = weight(0.25);
  light.force_ratio = {0.959, 0.004}, light.deformation_ratio = {1.17, 0.01}, light.frequency_ratio = {0.93, 0.002};
  light.damping_difference = {0.0011, 0.0004};
  light.force_per_weight_measured_N_per_kg = 4.39, light.force_per_weight_simulated_N_per_kg = 4.58;
  heavy = light, heavy.key = weight(0.25), heavy.force_ratio = {0.961, 0.003};
  d.signatures.weight_drops = {light, heavy};
  analysis::SoilBinSignature bin;
  bin.key = soilBin(40), bin.force_bias_percent = -37.5, bin.deformation_bias_percent = std::nan("");
  bin.end_rise_difference = 0.02, bin.fluctuation_ratio = 0.8, bin.spectral_slope_measured = -1.1, bin.spectral_slope_simulated = -0.9;
  d.signatures.soil_bins = {bin};
  d.considered = {{"clamp_compliance", "a rotational spring at the clamp, not a rigid root", "force per weight lower, deformation larger, frequency lower",
                   {}, {true, "force per weight 4.1 % low, deformation 17 % high"}},
                  {"force_sensor_gain", "the load cell's gain off", "the force's steady ratio off at every weight",
                   {}, {false, "frequency ratio 0.93 +- 0.01: changed, \"not a gain\""}}};
  d.baseline = baselineModel();
  d.models = {clampModel()};
  Localisation force{weight(0.125), "step_force_N", 2.45, 2.9, 0.04};
  force.residual_percent = 18.4, force.z = 11.2, force.p_value = 4e-29, force.significant = true;
  Localisation damping{weight(0.125), "damping_ratio", 0.012, 0.012, 0.0001};
  d.localisation = {force, damping};
  PhaseLocalisation end_wall;
  end_wall.key = soilBin(40), end_wall.model = "study as given", end_wall.phase = "end of stroke";
  end_wall.measured_N = 12.5, end_wall.simulated_N = 16.0, end_wall.sigma_N = 0.7, end_wall.residual_percent = 28.0, end_wall.z = 5.0;
  end_wall.p_value = 5.7e-7, end_wall.significant = true;
  d.phases = {end_wall};
  CalibrationShift modulus;
  modulus.spec.pointer = "/tools/0/fem/E_Pa", modulus.study_value = 4.06e9, modulus.fitted = 4.07e9, modulus.std_dev = 1e7;
  modulus.model_form_shift = 2e7, modulus.shift_percent = 0.246, modulus.z = 0.447, modulus.p_value = 0.65, modulus.cause = "young_modulus";
  d.shifts = {modulus};
  d.verdict = Verdict::Cause;
  d.named_model = 0;
  d.causes = {"clamp_compliance"};
  d.reason = "clamp_compliance: ln B 1419 over the calibrated baseline";
  d.gain_percent = 95.3, d.nominal_error_percent = 17.2, d.wall_time_s = 12;
  return d;
}

}  // namespace

TEST_CASE("calibrate's tables: every CSV cell equals its JSON value, the numbers given reach both", "[campaign][report]") {
  TempDir dir("calibrate-report");
  const StagedCalibration c = twoStages();
  const CalibrationOptions options;
  writeStaged(dir / "out", [&](analysis::StagedOutput& out) { writeCalibration(c, options, out, nullptr); });
  const nlohmann::json doc = toJson(c, options);
  checkCsvMatchesJson(readText(dir / "out" / "stages.csv"), doc["stages"]);
  checkCsvMatchesJson(readText(dir / "out" / "parameters.csv"), nestedRows(doc["stages"], "parameters"));
  checkCsvMatchesJson(readText(dir / "out" / "residuals.csv"), nestedRows(doc["stages"], "residuals"));

  const nlohmann::json& E = doc["fitted"]["/tools/0/fem/E_Pa"];
  CHECK(E["value"].get<double>() == 4.4987e9);
  CHECK(E["std_dev"].get<double>() == 2.8e6);
  CHECK(doc["fitted"]["/tools/0/fem/alpha_s"]["value"].is_null());                // unidentified: no value
  CHECK(doc["fitted"]["/tools/0/fem/alpha_s"]["std_dev"].is_null());              // infinite
  CHECK(doc["stages"][0]["parameters"][1]["best_point"].get<double>() == Approx(7e-3));  // what the calibrated study carries
  CHECK(doc["stages"][0]["unique"] == false);
  CHECK(doc["stages"][0]["distinct_minima"] == 2);
  CHECK(doc["stages"][1]["failed_runs"] == 1);
  const nlohmann::json& r = doc["stages"][0]["residuals"][0];
  CHECK(r["case"] == "PMMA_0.5kg");
  CHECK(r["initial_simulated"].get<double>() == 2.31);
  CHECK(r["simulated"].get<double>() == 2.449);
  CHECK(r["normalized"].get<double>() == Approx(-0.1).epsilon(1e-9));
  CHECK(doc["stages"][0]["residuals"][1]["missing"] == true);
  CHECK(doc["model_runs"] == 232);
  CHECK(doc["wall_time_s"].get<double>() == Approx(1275.9));

  const std::string md = readText(dir / "out" / "report.md");
  checkContains(md, {"| `/tools/0/fem/E_Pa` | 4.06e+09 | 4.4987e+09 | 2.8e+06 | 1e+09 - 1.6e+10 (log) |",
                     "| `/tools/0/fem/alpha_s` | 0.00055 | unidentified | - | 1e-06 - 0.01 (log) |",
                     "the calibrated study carries the best point found, 0.007,",
                     "| PMMA, 0.5 kg weight | step_force_N | 2.45 | 0.01 | 2.31 | 2.449 | -0.1 |",
                     "chi2 296 -> 0.02 over 2 quantities. NOT unique: 2 distinct minima",
                     "Model runs 8 (cache hits 0, failed DEM runs 1), objective evaluations 8, wall time 1234.5 s."});
}

TEST_CASE("diagnose's tables: every CSV cell equals its JSON value, the verdict and models reach both", "[campaign][report]") {
  TempDir dir("diagnose-report");
  const Diagnosis d = diagnosis();
  const DiagnosisSettings settings;
  writeStaged(dir / "out", [&](analysis::StagedOutput& out) { writeDiagnosis(d, settings, out, nullptr); });
  const nlohmann::json doc = toJson(d, settings, "extended_study.json");
  checkCsvMatchesJson(readText(dir / "out" / "models.csv"), doc["models"]);
  checkCsvMatchesJson(readText(dir / "out" / "localisation.csv"), doc["localisation"]);
  checkCsvMatchesJson(readText(dir / "out" / "phase_localisation.csv"), doc["phase_localisation"]);
  checkCsvMatchesJson(readText(dir / "out" / "calibration_shifts.csv"), doc["calibration_shifts"]);
  checkCsvMatchesJson(readText(dir / "out" / "parameters.csv"), nestedRows(doc["models"], "parameters"));
  checkCsvMatchesJson(readText(dir / "out" / "weight_signatures.csv"), doc["signatures"]["weight_drops"]);
  checkCsvMatchesJson(readText(dir / "out" / "soil_signatures.csv"), doc["signatures"]["soil_bins"]);

  CHECK(doc["verdict"] == "cause");
  CHECK(doc["causes"] == nlohmann::json::array({"clamp_compliance"}));
  CHECK(doc["cause"] == "clamp_compliance");
  CHECK(doc["gain_percent"].get<double>() == 95.3);
  CHECK(doc["extended_study"] == "extended_study.json");
  const nlohmann::json& baseline = doc["models"][0];
  CHECK(baseline["id"] == "baseline");
  CHECK(baseline["causes"].empty());
  const nlohmann::json& clamp = doc["models"][1];
  CHECK(clamp["id"] == "clamp_compliance");
  CHECK(clamp["probability"].get<double>() == 1.0);
  CHECK(clamp["log_evidence"].get<double>() == -14.25);
  CHECK(clamp["error_before_percent"].get<double>() == 17.2);
  CHECK(clamp["error_after_percent"].get<double>() == 0.15);
  CHECK(clamp["parameters"][1]["value"].get<double>() == 1.52);
  CHECK(clamp["parameters"][1]["std_dev"].get<double>() == 0.03);
  CHECK(doc["localisation"][0]["z"].get<double>() == 11.2);
  CHECK(doc["localisation"][0]["significant"] == true);
  CHECK(doc["localisation"][1]["significant"] == false);
  CHECK(doc["phase_localisation"][0]["phase"] == "end of stroke");
  CHECK(doc["phase_localisation"][0]["z"].get<double>() == 5.0);
  CHECK(doc["calibration_shifts"][0]["cause"] == "young_modulus");
  CHECK(doc["calibration_shifts"][0]["model_form_shift"].get<double>() == 2e7);
  CHECK(doc["calibration_shifts"][0]["significant"] == false);
  CHECK(doc["considered"][1]["evidence"] == "frequency ratio 0.93 +- 0.01: changed, \"not a gain\"");
  CHECK(doc["signatures"]["weight_drops"][1]["force_ratio"].get<double>() == 0.961);
  CHECK(doc["signatures"]["soil_bins"][0]["deformation_bias_percent"].is_null());

  const std::string md = readText(dir / "out" / "report.md");
  CHECK(md.find("# Diagnosis\n\n**Cause: `clamp_compliance`**") == 0);  // the verdict first
  checkContains(md, {"| PMMA, 0.125 kg weight | step_force_N | 18.4 | 11.2 | **yes** |",
                     "| `clamp_compliance` | 1 | 1.42e+03 | 0 | 17.2 -> 0.15 | 95.3 | 1.08e+03 -> 0.39 | E_Pa = 4.07e+09 +- 1e+07; "
                     "clamp_rotational_stiffness_Nm_per_rad = 1.52 +- 0.03 | leave one case out (2 folds) |",
                     "| 0.125 kg | 0.959 +- 0.004 | 1.17 +- 0.01 | 4.39 / 4.58 | 0.93 +- 0.002 | 0.0011 +- 0.0004 |",
                     "| 40 mm | -37.5 | - | 0.02 | 0.8 | -1.1 / -0.9 |",
                     "| PMMA, 40 mm depth | study as given | end of stroke | 12.5 | 16 | 28 | 5 | **yes** |",
                     "| `E_Pa` | 4.06e+09 | 4.07e+09 | 0.246 | 0.447 | no | young_modulus |"});
}

namespace {

// A finished campaign run of the PMMA 30 mm case: a synthetic calibrated recording (window means
// 25 N and 3 mm), 5400 s of wall time.
void writeFinishedPmma30Run(const fs::path& campaign_dir) {
  const fs::path run = campaign_dir / "pmma_coupled_30";
  fs::create_directories(run);
  fs::copy_file(fs::path(DEMFEM_SOURCE_DIR) / "studies" / "paper" / "pmma_coupled_30.json", run / "study.json");
  analysis::SoilBinTruth truth;
  truth.force_N = 25, truth.deformation_mm = 3;
  analysis::SyntheticRecording recording = analysis::makeSoilBinRecording(truth, analysis::RecordingFormat::Calibrated);
  recording.sidecar["complete"] = true;
  analysis::writeSyntheticRecording(recording, run / "sensors.csv");
  std::ofstream(run / kRunRecord) << R"({"wall_time_s": 5400})";
}

// Report options over `campaign_dir` with an estimate of 1e5 s per metre of depth.
ReportOptions paperReportOptions(const fs::path& campaign_dir) {
  ReportOptions options;
  options.directory = campaign_dir;
  options.estimate_wall_s = [](const study::Study& s) { return 1e5 * s.tools.front().motion.depth_m; };
  return options;
}

}  // namespace

TEST_CASE("the paper report's table: every CSV cell equals its JSON value, an unfinished case has null run figures and the cost of the finished runs of its model",
          "[campaign][report]") {
  TempDir dir("paper-report");
  const fs::path studies = fs::path(DEMFEM_SOURCE_DIR) / "studies" / "paper";
  writeFinishedPmma30Run(dir / "campaign");
  const ReportOptions options = paperReportOptions(dir / "campaign");
  nlohmann::json doc;
  writeStaged(dir / "report", [&](analysis::StagedOutput& out) {
    doc = writePaperReport({studies / "pmma_coupled_30.json", studies / "s235_dem_18.json", studies / "s235_coupled_18.json"}, options, out);
  });
  checkCsvMatchesJson(readText(dir / "report" / "paper-reproduction.csv"), doc["cases"]);

  const nlohmann::json& pmma = doc["cases"][0];
  CHECK(pmma["finished"] == true);
  CHECK(pmma["depth_mm"].get<double>() == Approx(30));
  CHECK(pmma["force_mean_N"].get<double>() == Approx(25).epsilon(0.01));
  CHECK(pmma["deformation_mean_mm"].get<double>() == Approx(3).epsilon(0.01));
  CHECK(pmma["window_begin_mm"].get<double>() == Approx(100));
  CHECK(pmma["window_end_mm"].get<double>() == Approx(500));
  CHECK(pmma["fit_signal"] == "deformation");
  CHECK(pmma["wall_time_s"].get<double>() == 5400);
  CHECK(pmma["paper_hours"].get<double>() == 54);  // Table 1
  CHECK(pmma["paper_simulated_tilt_min_deg"].get<double>() == 2.1);
  // The synthetic tilt is 1.2 deg per mm of deformation: 3.6 deg over the tilt window, against the
  // midpoint 2.2 deg of the paper's simulated 2.1-2.3 deg.
  CHECK(pmma["tilt_mean_deg"].get<double>() == Approx(3.6).epsilon(0.02));
  CHECK(pmma["tilt_minus_paper_simulated_deg"].get<double>() == Approx(1.4).margin(0.08));
  // Its full-scale projection: the estimate (3000 s) times measured / estimated of the run (1).
  CHECK(pmma["projected_full_scale_h"].get<double>() == Approx(5400.0 / 3600));
  const nlohmann::json& s235 = doc["cases"][1];
  CHECK(s235["finished"] == false);
  CHECK(s235["force_mean_N"].is_null());
  CHECK(s235["tilt_min_deg"].is_null());
  CHECK(s235["projected_full_scale_h"].get<double>() == Approx(1800.0 / 3600));  // no finished DEM run: the estimate
  CHECK(s235["deforms"] == false);  // DEM only: a rigid tool
  // A DEM-FEM case not run: its estimate (1800 s) times measured / estimated of the finished
  // DEM-FEM run (5400 / 3000 s).
  const nlohmann::json& coupled = doc["cases"][2];
  CHECK(coupled["finished"] == false);
  CHECK(coupled["projected_full_scale_h"].get<double>() == Approx(1800.0 * 1.8 / 3600));

  const std::string md = readText(dir / "report" / "paper-reproduction.md");
  checkContains(md, {"| pmma_coupled_30 | PMMA | DEM-FEM | 30 | ",
                     "| s235_dem_18 | S235 | DEM | 18 | ",
                     "| not finished |  |  |",
                     "| pmma_coupled_30 | 2.00-2.10 | 2.10-2.30 | ",
                     "| s235_dem_18 | 44 | not finished | 0.5 (estimate) | 0.011 |  |",
                     "| pmma_coupled_30 | 54 | 5400 s (600 mm stroke) | 1.5 (measured cost) | 0.028 |",
                     "| s235_coupled_18 | 28 | not finished | 0.9 (estimate x 1.8, measured / estimated of 1 finished DEM-FEM run) | 0.032 |  |"});
}

TEST_CASE("the paper report keeps each evaluation: without its run a case is reported from it, as before", "[campaign][report]") {
  TempDir dir("paper-report-kept");
  const fs::path studies = fs::path(DEMFEM_SOURCE_DIR) / "studies" / "paper";
  writeFinishedPmma30Run(dir / "campaign");
  ReportOptions options = paperReportOptions(dir / "campaign");
  options.label = "commit A";
  const std::vector<fs::path> files{studies / "pmma_coupled_30.json", studies / "s235_dem_18.json"};
  nlohmann::json first, second;
  writeStaged(dir / "report", [&](analysis::StagedOutput& out) { first = writePaperReport(files, options, out); });
  REQUIRE(fs::exists(dir / "report" / "paper-runs" / "pmma_coupled_30.json"));
  CHECK_FALSE(fs::exists(dir / "report" / "paper-runs" / "s235_dem_18.json"));
  const std::string csv_first = readText(dir / "report" / "paper-reproduction.csv");
  const std::string kept_first = readText(dir / "report" / "paper-runs" / "pmma_coupled_30.json");

  // Another machine: no run directory, a later label; the kept evaluation stands in for the run.
  fs::remove_all(dir / "campaign");
  options.label = "commit B";
  writeStaged(dir / "report", [&](analysis::StagedOutput& out) { second = writePaperReport(files, options, out); });
  const nlohmann::json& pmma = second["cases"][0];
  CHECK(pmma["finished"] == true);
  CHECK(pmma["kept"] == true);
  CHECK(pmma["runs_label"] == "commit A");
  for (const char* key : {"force_mean_N", "force_std_N", "deformation_mean_mm", "fit_b", "tilt_min_deg", "tilt_mean_deg", "wall_time_s",
                          "projected_full_scale_h"})
    CHECK(pmma[key] == first["cases"][0][key]);
  CHECK(readText(dir / "report" / "paper-runs" / "pmma_coupled_30.json") == kept_first);
  CHECK(first["cases"][0]["kept"] == false);
  checkContains(readText(dir / "report" / "paper-reproduction.md"), {"kept: commit A |"});
  // The CSV differs only in the two provenance columns.
  CHECK(csv_first != readText(dir / "report" / "paper-reproduction.csv"));

  SECTION("a kept evaluation of another version of the study is not used, and the report says so") {
    nlohmann::json kept = nlohmann::json::parse(kept_first);
    kept["study_fnv1a64"] = "0000000000000000";
    std::ofstream(dir / "report" / "paper-runs" / "pmma_coupled_30.json") << kept.dump();
    nlohmann::json third;
    writeStaged(dir / "report", [&](analysis::StagedOutput& out) { third = writePaperReport(files, options, out); });
    CHECK(third["cases"][0]["finished"] == false);
    checkContains(readText(dir / "report" / "paper-reproduction.md"), {"Not used: the kept evaluations of pmma_coupled_30"});
  }
  SECTION("a kept evaluation stays in use after the study's notes are edited") {
    nlohmann::json edited = nlohmann::json::parse(readText(studies / "pmma_coupled_30.json"));
    edited["notes"] = "a note written after the run";
    fs::create_directories(dir / "edited");
    std::ofstream(dir / "edited" / "pmma_coupled_30.json") << edited.dump(2);
    const std::vector<fs::path> edited_files{dir / "edited" / "pmma_coupled_30.json", studies / "s235_dem_18.json"};
    nlohmann::json third;
    writeStaged(dir / "report", [&](analysis::StagedOutput& out) { third = writePaperReport(edited_files, options, out); });
    CHECK(third["cases"][0]["kept"] == true);
    CHECK(third["cases"][0]["force_mean_N"] == first["cases"][0]["force_mean_N"]);
  }
  SECTION("a damaged kept evaluation is an error naming the file") {
    std::ofstream(dir / "report" / "paper-runs" / "pmma_coupled_30.json") << R"({"case": "pmma_coupled_30"})";
    analysis::StagedOutput out(dir / "report");
    CHECK_THROWS_WITH(writePaperReport(files, options, out),
                      Catch::Matchers::Contains("pmma_coupled_30.json: not a kept evaluation of pmma_coupled_30"));
  }
}

namespace {

// Particle and tool files of a run (vtk/particles.pvd, vtk/dem-PMMA.pvd) like a coupled run's:
// a lattice of 10 mm spheres (x 0-100, y 0-80, z 0-400 mm, surface at 80 mm) and a 20 mm wide,
// 10 mm thick plate whose tip is 42 mm deep, at 0, 100, ..., 400 mm of displacement (0.1 s apart).
// At 300 mm the particles with centres at x 35-65, y 25-75 and z 330-370 mm move at 60 mm/s along
// the travel (the region in motion: 60 mm deep, 40 mm long, 40 mm wide), the rest are still.
void writeParticleFiles(const fs::path& run_dir) {
  const fs::path vtk = run_dir / "vtk";
  fs::create_directories(vtk);
  adapter::VtkSeries particles(vtk / "particles.pvd"), tool(vtk / "dem-PMMA.pvd");
  for (int frame = 0; frame <= 4; ++frame) {
    const double time_s = 0.1 * frame, z_tool = 0.025 + 0.1 * frame;
    vtkio::Dataset soil;
    soil.time_s = time_s;
    vtkio::PointArray velocity{"velocity_m_s", 3, {}}, radius{"radius_m", 1, {}}, layer{"layer", 1, {}, vtkio::ValueType::Int32};
    for (int k = 0; k < 40; ++k)
      for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 10; ++i) {
          const double x = 0.005 + 0.01 * i, y = 0.005 + 0.01 * j, z = 0.005 + 0.01 * k;
          const bool moving = frame == 3 && x > 0.034 && x < 0.066 && y > 0.024 && z > 0.329 && z < 0.371;
          soil.points.insert(soil.points.end(), {x, y, z});
          velocity.values.insert(velocity.values.end(), {0.0, 0.0, moving ? 0.06 : 0.0});
          radius.values.push_back(0.005);
          layer.values.push_back(j < 4 ? 1 : 0);
        }
    soil.arrays = {velocity, radius, layer};
    vtkio::Dataset plate;
    plate.time_s = time_s;
    for (const double x : {0.04, 0.06})
      for (const double y : {0.038, 0.12})
        for (const double z : {z_tool - 0.005, z_tool + 0.005}) plate.points.insert(plate.points.end(), {x, y, z});
    plate.triangles = {{0, 1, 3}, {0, 3, 2}, {4, 6, 7}, {4, 7, 5}, {0, 4, 5}, {0, 5, 1}, {2, 3, 7}, {2, 7, 6}, {0, 2, 6}, {0, 6, 4}, {1, 5, 7}, {1, 7, 3}};
    const std::string name = "frame_" + std::to_string(frame);
    adapter::writeFileAtomically(vtk / ("particles_" + name + ".vtp"), vtkio::encode(soil, vtkio::Format::PolyData));
    adapter::writeFileAtomically(vtk / ("dem-PMMA_" + name + ".vtp"), vtkio::encode(plate, vtkio::Format::PolyData));
    particles.add(time_s, "particles_" + name + ".vtp");
    tool.add(time_s, "dem-PMMA_" + name + ".vtp");
  }
}

}  // namespace

TEST_CASE("the committed kept evaluations are of the shipped paper studies, also after keys were added to the study file", "[campaign][report]") {
  // A key added later at the default that gives the earlier numbers must not make the kept runs
  // "of another version of their study": the report would drop hours of full-scale runs.
  TempDir dir("paper-report-committed");
  const fs::path source = fs::path(DEMFEM_SOURCE_DIR);
  std::vector<fs::path> files;
  // The committed runs are of the paper studies before they took the epsd rolling law (2026-12-08,
  // docs/builtin-dem.md, "A bed at rest"): their studies are the shipped ones with EDEM's standard
  // rolling friction, until the cases are run again.
  fs::create_directories(dir / "studies");
  for (const auto& entry : fs::directory_iterator(source / "docs" / "paper-runs")) {
    nlohmann::json study = nlohmann::json::parse(readText(source / "studies" / "paper" / entry.path().filename()));
    study["soil"]["contact"]["rolling"] = "edem-standard";
    std::ofstream(dir / "studies" / entry.path().filename()) << study.dump(2);
    files.push_back(dir / "studies" / entry.path().filename());
    fs::create_directories(dir / "report" / "paper-runs");
    fs::copy_file(entry.path(), dir / "report" / "paper-runs" / entry.path().filename());
  }
  REQUIRE(files.size() >= 2);
  std::sort(files.begin(), files.end());
  fs::create_directories(dir / "campaign");
  nlohmann::json doc;
  writeStaged(dir / "report", [&](analysis::StagedOutput& out) { doc = writePaperReport(files, paperReportOptions(dir / "campaign"), out); });
  for (const auto& c : doc["cases"]) {
    INFO(c.at("name"));
    CHECK(c["kept"] == true);
    // A DEM-only run drags a rigid tool: no deformation, said so, instead of a measured 0 mm.
    if (c.at("model") == "DEM") CHECK(c.at("deformation_mean_mm").is_null());
  }
  const std::string md_kept = readText(dir / "report" / "paper-reproduction.md");
  CHECK(md_kept.find("| s235_dem_42 | S235 | DEM | 42 | 32.22 (32.22) | finished | 600 | 100-500 | ") != std::string::npos);
  CHECK(md_kept.find("| rigid tool |") != std::string::npos);
  CHECK(readText(dir / "report" / "paper-reproduction.md").find("Not used") == std::string::npos);

  SECTION("but not after a value that changes the numbers") {
    nlohmann::json changed = nlohmann::json::parse(readText(files.front()));
    changed["soil"]["contact"]["rolling_regularisation_fraction"] = 0.05;
    fs::create_directories(dir / "changed");
    std::ofstream(dir / "changed" / files.front().filename()) << changed.dump(2);
    std::vector<fs::path> changed_files = files;
    changed_files.front() = dir / "changed" / files.front().filename();
    writeStaged(dir / "report", [&](analysis::StagedOutput& out) { doc = writePaperReport(changed_files, paperReportOptions(dir / "campaign"), out); });
    CHECK(doc["cases"][0]["kept"] == false);
    CHECK(doc["cases"][1]["kept"] == true);
  }
}

TEST_CASE("the paper report measures Fig. 16's soil motion of a run with particle files at 300 mm, and keeps it", "[campaign][report]") {
  TempDir dir("paper-report-soil-motion");
  const fs::path studies = fs::path(DEMFEM_SOURCE_DIR) / "studies" / "paper";
  writeFinishedPmma30Run(dir / "campaign");
  const fs::path run = dir / "campaign" / "pmma_coupled_42";
  fs::rename(dir / "campaign" / "pmma_coupled_30", run);
  fs::copy_file(studies / "pmma_coupled_42.json", run / "study.json", fs::copy_options::overwrite_existing);
  writeParticleFiles(run);
  ReportOptions options = paperReportOptions(dir / "campaign");
  const analysis::GnuplotRenderer renderer;
  options.renderer = &renderer;
  const std::vector<fs::path> files{studies / "pmma_coupled_42.json", studies / "s235_coupled_42.json"};
  nlohmann::json first, second;
  writeStaged(dir / "report", [&](analysis::StagedOutput& out) { first = writePaperReport(files, options, out); });
  checkCsvMatchesJson(readText(dir / "report" / "paper-reproduction.csv"), first["cases"]);

  const nlohmann::json& pmma = first["cases"][0];
  CHECK(pmma["soil_motion_at_mm"].get<double>() == Approx(300).margin(1e-9));
  CHECK(pmma["moving_depth_mm"].get<double>() == Approx(60).margin(1e-9));  // surface 80 mm, lowest sphere bottom 20 mm
  CHECK(pmma["moving_length_mm"].get<double>() == Approx(40).margin(1e-9));
  CHECK(pmma["moving_width_mm"].get<double>() == Approx(40).margin(1e-9));
  CHECK(pmma["moving_particles"] == 4 * 6 * 4);
  CHECK(pmma["paper_moving_depth_mm"].get<double>() == 83);  // Section 3.5
  CHECK(pmma["moving_depth_minus_paper_mm"].get<double>() == Approx(-23).margin(1e-9));
  // In front of the plate (x 40-60, y 38-80, z 330-340.5 mm): the centres at x 45, 55 mm, y 45-75 mm, z 335 mm.
  CHECK(pmma["front_particles"] == 2 * 4);
  CHECK(pmma["front_speed_min_mm_s"].get<double>() == Approx(60));
  CHECK(pmma["front_speed_max_mm_s"].get<double>() == Approx(60));
  CHECK(pmma["paper_front_speed_max_mm_s"].get<double>() == 100);
  CHECK(pmma["streamline_order"].get<double>() == Approx(1.0));  // every moving particle moves along z
  // A case without particle files has the paper's numbers and none of ours.
  const nlohmann::json& s235 = first["cases"][1];
  CHECK(s235["paper_moving_depth_mm"].get<double>() == 55);
  CHECK(s235["moving_depth_mm"].is_null());
  CHECK(s235["streamlines"].is_null());
  checkContains(readText(dir / "report" / "paper-reproduction.md"),
                {"## Soil motion at 300 mm, 42 mm deep", "| pmma_coupled_42 | DEM-FEM | 83 | 60 (at 300 mm) | -23 | 40-100 | 60-60 (60; 8) | 40 x 40 |",
                 "| s235_coupled_42 | DEM-FEM | 55 | no particle files |  | 23-40 |"});

  const std::string kept_first = readText(dir / "report" / "paper-runs" / "pmma_coupled_42.json");
  const std::string plot_first = readText(dir / "report" / "plots" / "paper_soil_motion.gp");
  CHECK(plot_first.find("pmma_coupled_42 at 300.0 mm") != std::string::npos);

  // Without the run (another machine), the kept evaluation gives the same soil motion and plot.
  fs::remove_all(dir / "campaign");
  writeStaged(dir / "report", [&](analysis::StagedOutput& out) { second = writePaperReport(files, options, out); });
  REQUIRE(second["cases"][0]["kept"] == true);
  for (const char* key : {"moving_depth_mm", "moving_length_mm", "front_speed_median_mm_s", "front_particles", "streamline_order", "streamlines",
                          "mean_streamline_length_mm"})
    CHECK(second["cases"][0][key] == first["cases"][0][key]);
  CHECK(readText(dir / "report" / "paper-runs" / "pmma_coupled_42.json") == kept_first);
  CHECK(readText(dir / "report" / "plots" / "paper_soil_motion.gp") == plot_first);
}
