// evaluate / compare end to end on synthetic recordings: numbers known by construction, files and
// plots written, nothing left under a final name when something fails.
#include "demfem/analysis/workflow.hpp"
#include "demfem/analysis/synthetic.hpp"
#include "support/csv_json.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace demfem::analysis;
using demfem::support::checkCsvMatchesJson;
using demfem::support::readText;
using demfem::support::TempDir;
namespace fs = std::filesystem;

namespace {

// Measured: 2 raw repeats of PMMA 30 mm plus one raw 1 kg weight drop. Simulated: the same cases in
// the FEM client's format with force and deformation scaled by `scale`, a steeper spectrum
// (exponent b_sim) and a weight drop at a higher frequency.
void writeCases(const fs::path& measured, const fs::path& simulated, double scale, double b_measured, double b_simulated) {
  fs::create_directories(measured);
  fs::create_directories(simulated);
  for (int r = 1; r <= 2; ++r) {
    SoilBinTruth truth;
    truth.repeat = r;
    truth.seed = 50 + static_cast<std::uint64_t>(r);
    truth.fluctuation_b = b_measured;
    writeSyntheticRecording(makeSoilBinRecording(truth, RecordingFormat::Raw), measured / ("pmma30_r" + std::to_string(r) + ".csv"));
  }
  SoilBinTruth sim;
  sim.seed = 77;
  sim.sample_rate_Hz = 100.0;
  sim.force_N *= scale;
  sim.deformation_mm *= scale;
  sim.fluctuation_b = b_simulated;
  writeSyntheticRecording(makeSoilBinRecording(sim, RecordingFormat::Calibrated), simulated / "pmma30.csv");

  WeightDropTruth drop;
  drop.seed = 5;
  writeSyntheticRecording(makeWeightDropRecording(drop, RecordingFormat::Raw), measured / "weight1kg.csv");
  WeightDropTruth drop_sim = drop;
  drop_sim.sample_rate_Hz = 500.0;
  drop_sim.drop_time_s = 0.2;
  drop_sim.frequency_Hz = 3.3;
  drop_sim.noise_fraction = 0.0;
  writeSyntheticRecording(makeWeightDropRecording(drop_sim, RecordingFormat::Calibrated), simulated / "weight1kg.csv");
}

}  // namespace

TEST_CASE("compare recovers mean differences, spectral exponents and calibration differences by construction", "[analysis]") {
  TempDir dir("compare");
  writeCases(dir / "measured", dir / "simulated", 1.10, -0.8, -1.3);
  AnalysisSettings settings;
  // The fluctuation lives in 0.5-25 Hz; below 0.5 Hz and near Nyquist the bins hold only noise.
  settings.fft_low_Hz = 0.5;
  settings.fft_high_Hz = 20.0;
  const ComparisonResult result = compare(readRecordings({dir / "measured"}), readRecordings({dir / "simulated"}), settings);

  REQUIRE(result.soil_bin.size() == 1);
  REQUIRE(result.calibration.size() == 1);
  CHECK(result.unmatched_cases.empty());
  const SoilBinComparison& c = result.soil_bin.front();
  CHECK(c.measured.repeats.size() == 2);
  // Simulated means are 10 % higher by construction (each side within 1 %).
  CHECK(c.force_difference_percent == Approx(10.0).margin(2.0));
  CHECK(c.deformation_difference_percent == Approx(10.0).margin(2.0));
  // Spectral exponents of the fluctuation (dense random-phase sinusoids, 0.5-25 Hz): within 0.15.
  CHECK(c.deformation_spectrum.measured_fit.b == Approx(-0.8).margin(0.15));
  CHECK(c.deformation_spectrum.simulated_fit.b == Approx(-1.3).margin(0.15));
  CHECK(c.force_spectrum.measured_fit.b == Approx(-0.8).margin(0.15));
  CHECK(c.deformation_spectrum.measured_fit.f_high_Hz <= 20.0);
  // The simulated fluctuation is weaker at high frequency, so the fitted ratio is below 1.
  CHECK(c.deformation_spectrum.mean_fitted_ratio < 1.0);

  const CalibrationComparison& w = result.calibration.front();
  CHECK(w.measured.deformation.frequency_Hz.mean == Approx(3.0).epsilon(0.01));
  CHECK(w.simulated.deformation.frequency_Hz.mean == Approx(3.3).epsilon(0.01));
  CHECK(w.measured.force.steady.mean == Approx(4.5).epsilon(0.005));
  CHECK(w.measured.deformation.damping_ratio.mean == Approx(0.05).epsilon(0.1));
  REQUIRE(w.correlations.size() == 1);
  // First maxima aligned: shift = measured peak - simulated peak = (1.0 + 1/6) - (0.2 + 1/6.6) s.
  CHECK(w.correlations.front().deformation.shift_s == Approx(1.0 + 0.5 / 3.0 - 0.2 - 0.5 / 3.3).margin(0.01));
  CHECK(w.correlations.front().deformation.correlation < 0.99);  // 10 % frequency mismatch
  CHECK(w.correlations.front().deformation.correlation > 0.3);

  const auto json = toJson(result, settings);
  // One object per row of means.csv and calibration.csv, keyed by the CSV's column names.
  CHECK(json["means"][0]["force_difference_percent"].get<double>() == Approx(c.force_difference_percent));
  CHECK(json["means"][0]["measured_repeats"] == c.measured.repeats.size());  // a JSON-only column
  REQUIRE(json["calibration"].size() == 2);
  CHECK(json["calibration"][0]["signal"] == "deformation_mm");
  CHECK(json["calibration"][0]["measured_frequency_mean_Hz"].get<double>() == Approx(3.0).epsilon(0.01));
  CHECK(json["correlations"][0]["deformation_shift_s"].get<double>() == Approx(w.correlations.front().deformation.shift_s));
  CHECK(json["settings"]["fft_high_Hz"].get<double>() == 20.0);
}

TEST_CASE("compare lists cases present on one side only and fails when none match", "[analysis]") {
  TempDir dir("compare-unmatched");
  writeCases(dir / "measured", dir / "simulated", 1.0, -0.8, -0.8);
  SoilBinTruth other;
  other.depth_mm = 42.0;
  other.seed = 3;
  writeSyntheticRecording(makeSoilBinRecording(other, RecordingFormat::Raw), dir / "measured" / "pmma42.csv");
  const ComparisonResult result = compare(readRecordings({dir / "measured"}), readRecordings({dir / "simulated"}), AnalysisSettings{});
  CHECK(result.unmatched_cases == std::vector<std::string>{"PMMA, 42 mm depth (measured only)"});
  CHECK_THROWS_WITH(compare(readRecordings({dir / "measured" / "pmma42.csv"}), readRecordings({dir / "simulated"}), AnalysisSettings{}),
                    Catch::Contains("no case appears among both"));
}

TEST_CASE("evaluate and compare write tables, evaluated curves, SVG plots and a report", "[analysis]") {
  TempDir dir("outputs");
  writeCases(dir / "measured", dir / "simulated", 1.05, -0.8, -1.0);
  const AnalysisSettings settings;
  const GnuplotRenderer renderer;

  const EvaluationResult evaluation = evaluate(readRecordings({dir / "measured"}), settings);
  {
    StagedOutput out(dir / "evaluation");
    writeEvaluation(evaluation, settings, out, &renderer);
    out.commit();
  }
  for (const char* name : {"report.md", "soil_bin_runs.csv", "soil_bin_cases.csv", "calibration_runs.csv", "runs/PMMA_30mm_r1.csv",
                           "runs/PMMA_30mm_r1.json", "plots/PMMA_30mm_curves.svg", "plots/PMMA_30mm_curves.gp", "plots/means.svg",
                           "plots/PMMA_1kg_history.svg"})
    CHECK(fs::exists(dir / "evaluation" / name));
  const std::string report = readText(dir / "evaluation" / "report.md");
  CHECK_THAT(report, Catch::Contains("![PMMA, 30 mm depth: force and deformation against tool displacement](plots/PMMA_30mm_curves.svg)"));
  CHECK_THAT(readText(dir / "evaluation" / "plots" / "PMMA_30mm_curves.svg"), Catch::Contains("</svg>"));
  // No staged leftovers.
  for (const auto& entry : fs::recursive_directory_iterator(dir / "evaluation")) CHECK(entry.path().extension() != ".partial");
  const auto evaluation_json = toJson(evaluation, settings);
  for (const char* table : {"soil_bin_runs", "soil_bin_cases", "calibration_runs"})
    checkCsvMatchesJson(readText(dir / "evaluation" / (std::string(table) + ".csv")), evaluation_json[table]);

  // The evaluated curves are a valid calibrated recording: feeding them back gives the same means.
  const auto reread = evaluate(readRecordings({dir / "evaluation" / "runs"}), settings);
  REQUIRE(reread.soil_bin_cases.size() == 1);
  CHECK(reread.soil_bin_cases[0].force_mean_N == Approx(evaluation.soil_bin_cases[0].force_mean_N).epsilon(1e-6));

  const ComparisonResult comparison = compare(readRecordings({dir / "measured"}), readRecordings({dir / "simulated"}), settings);
  {
    StagedOutput out(dir / "comparison");
    writeComparison(comparison, settings, out, &renderer);
    out.commit();
  }
  for (const char* name : {"report.md", "means.csv", "spectra.csv", "calibration.csv", "spectra/PMMA_30mm_r1_measured.csv",
                           "spectra/PMMA_30mm_r1_simulated.csv", "plots/means.svg", "plots/PMMA_30mm_curves.svg", "plots/PMMA_30mm_spectra.svg",
                           "plots/PMMA_1kg_history.svg", "plots/PMMA_1kg_response.svg"})
    CHECK(fs::exists(dir / "comparison" / name));
  const std::string means = readText(dir / "comparison" / "means.csv");
  CHECK_THAT(means, Catch::StartsWith("case,tool,depth_mm,measured_force_mean_N"));
  CHECK_THAT(means, Catch::Contains("PMMA_30mm,PMMA,30,"));
  const auto comparison_json = toJson(comparison, settings);
  for (const char* table : {"means", "spectra", "calibration"})
    checkCsvMatchesJson(readText(dir / "comparison" / (std::string(table) + ".csv")), comparison_json[table]);
}

TEST_CASE("a plot that cannot be drawn fails loudly and leaves no output under a final name", "[analysis]") {
  TempDir dir("plot-failure");
  writeCases(dir / "measured", dir / "simulated", 1.0, -0.8, -0.8);
  const AnalysisSettings settings;
  const EvaluationResult evaluation = evaluate(readRecordings({dir / "measured"}), settings);
  const GnuplotRenderer missing("demfem-no-such-gnuplot");
  {
    StagedOutput out(dir / "evaluation");
    CHECK_THROWS_WITH(writeEvaluation(evaluation, settings, out, &missing),
                      Catch::Contains("cannot start 'demfem-no-such-gnuplot'") && Catch::Contains("--no-plots"));
  }
  // Nothing committed, staged files removed.
  std::size_t files_left = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir / "evaluation")) files_left += entry.is_regular_file() ? 1 : 0;
  CHECK(files_left == 0);

  // Without a renderer the report says plots were not requested.
  StagedOutput out(dir / "no-plots");
  writeEvaluation(evaluation, settings, out, nullptr);
  out.commit();
  CHECK_THAT(readText(dir / "no-plots" / "report.md"), Catch::Contains("Plots were not requested"));
  CHECK_FALSE(fs::exists(dir / "no-plots" / "plots"));
}

TEST_CASE("gnuplot errors in a figure are reported with gnuplot's message", "[analysis]") {
  TempDir dir("plot-error");
  Figure figure;
  figure.title = "log axis with only non-positive values";
  XYPanel panel{"bad", "x", "y", true, true, {}};
  panel.series.push_back(Series{"values", {-1.0, -2.0, -3.0}, {-1.0, -2.0, -3.0}, kMeasuredColor, SeriesStyle::Line, 1.0});
  figure.panels = {panel};
  const GnuplotRenderer renderer;
  CHECK_THROWS_AS(renderer.render(figure, dir / "bad.gp", dir / "bad.svg"), PlotError);
  CHECK_FALSE(fs::exists(dir / "bad.svg"));

  // A valid figure renders deterministically.
  Figure good;
  good.title = "line";
  good.panels = {XYPanel{"p", "x", "y", false, false, {Series{"s", {0.0, 1.0, 2.0}, {1.0, 3.0, 2.0}, kMeasuredColor, SeriesStyle::Line, 1.0}}}};
  renderer.render(good, dir / "a.gp", dir / "a.svg");
  renderer.render(good, dir / "b.gp", dir / "b.svg");
  CHECK(readText(dir / "a.svg") == readText(dir / "b.svg"));
  CHECK(renderer.script(good) == readText(dir / "a.gp"));
}

TEST_CASE("long series are thinned to min/max buckets that keep every extreme, also on log axes", "[analysis]") {
  Series spike{"spiky", {}, {}, kMeasuredColor, SeriesStyle::Points, 1.0};
  for (int i = 1; i <= 20000; ++i) {
    spike.x.push_back(0.01 * i);
    spike.y.push_back(i == 12345 ? 99.0 : 1.0 / i);  // one spike and a log-log power law
  }
  const GnuplotRenderer renderer("gnuplot", 200);
  for (const bool log_axes : {false, true}) {
    Figure figure;
    figure.title = "thinning";
    figure.panels = {XYPanel{"p", "x", "y", log_axes, log_axes, {spike}}};
    const std::string script = renderer.script(figure);
    const auto begin = script.find("$p0s0 << EOD\n") + 13;
    const std::string block = script.substr(begin, script.find("EOD\n", begin) - begin);
    const auto lines = std::count(block.begin(), block.end(), '\n');
    CHECK(lines <= 200);
    CHECK(lines >= 100);
    CHECK_THAT(block, Catch::Contains("123.45 99\n"));  // the spike survives
    CHECK_THAT(block, Catch::StartsWith("0.01 1\n"));     // so does the first (largest) point
    if (log_axes) CHECK_THAT(block, Catch::Contains("0.02 0.5\n"));  // sparse low decade kept point by point
  }
}

TEST_CASE("the shipped example data compare with the offsets they were made with", "[analysis]") {
  const fs::path data = fs::path(DEMFEM_SOURCE_DIR) / "examples" / "data";
  AnalysisSettings settings;
  settings.fft_low_Hz = 0.5;
  const ComparisonResult result = compare(readRecordings({data / "measured"}), readRecordings({data / "simulated"}), settings);
  REQUIRE(result.soil_bin.size() == 2);
  REQUIRE(result.calibration.size() == 1);
  // analysis/tools/make_example_recordings.cpp: simulated means +8 % at 18 mm, -15 % at 30 mm
  // (repeats at -3/0/+3 % average to the nominal value; each mean within 1 %).
  CHECK(result.soil_bin[0].key.depth_mm == 18.0);
  CHECK(result.soil_bin[0].force_difference_percent == Approx(8.0).margin(1.5));
  CHECK(result.soil_bin[1].deformation_difference_percent == Approx(-15.0).margin(1.5));
  CHECK(result.calibration[0].simulated.deformation.frequency_Hz.mean == Approx(3.2).epsilon(0.01));
  CHECK(result.calibration[0].simulated.deformation.damping_ratio.mean == Approx(0.065).epsilon(0.05));
}

TEST_CASE("a simulated tool of another name is matched by case when each side has one tool", "[analysis]") {
  TempDir dir("one-tool");
  fs::create_directories(dir / "measured");
  fs::create_directories(dir / "simulated");
  WeightDropTruth measured;
  measured.seed = 8;
  writeSyntheticRecording(makeWeightDropRecording(measured, RecordingFormat::Raw), dir / "measured" / "pmma_1kg.csv");
  WeightDropTruth simulated = measured;
  simulated.tool = "blade";  // a study of one's own naming its tool otherwise
  simulated.frequency_Hz = 3.3;
  simulated.noise_fraction = 0.0;
  writeSyntheticRecording(makeWeightDropRecording(simulated, RecordingFormat::Calibrated), dir / "simulated" / "blade_1kg.csv");
  const auto m = readRecordings({dir / "measured"});
  const auto s = readRecordings({dir / "simulated"});
  REQUIRE(singleToolMatch(m, s) == std::optional<std::string>("PMMA"));
  const ComparisonResult result = compare(m, s, AnalysisSettings{});
  REQUIRE(result.calibration.size() == 1);
  CHECK(result.unmatched_cases.empty());
  CHECK(result.calibration[0].simulated.deformation.frequency_Hz.mean == Approx(3.3).epsilon(0.005));
  REQUIRE(result.simulated_tool_matched_as);
  CHECK(result.simulated_tool_matched_as->first == "blade");
  CHECK(toJson(result, AnalysisSettings{})["simulated_tool_matched_as"]["measured"] == "PMMA");

  // With two measured tools the names must match: the blade stays unmatched.
  WeightDropTruth s235 = measured;
  s235.tool = "S235";
  writeSyntheticRecording(makeWeightDropRecording(s235, RecordingFormat::Raw), dir / "measured" / "s235_1kg.csv");
  const auto two = readRecordings({dir / "measured"});
  CHECK_FALSE(singleToolMatch(two, s));
  CHECK_THROWS_WITH(compare(two, s, AnalysisSettings{}), Catch::Contains("blade, 1 kg weight (simulated only)"));
}
