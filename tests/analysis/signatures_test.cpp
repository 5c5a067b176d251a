// Discrepancy signatures (analysis/signatures.hpp) recovered from synthetic recordings whose
// differences are known by construction (analysis/synthetic.hpp).
#include "support/temp_dir.hpp"

#include "demfem/analysis/signatures.hpp"
#include "demfem/analysis/synthetic.hpp"

#include <catch2/catch.hpp>

using namespace demfem::analysis;
using demfem::support::TempDir;

namespace {

void writeWeight(const std::filesystem::path& dir, double mass_kg, double force_N, double deformation_mm, double frequency_Hz,
                 double damping, RecordingFormat format) {
  WeightDropTruth t;
  t.mass_kg = mass_kg;
  t.force_N = force_N;
  t.deformation_mm = deformation_mm;
  t.frequency_Hz = frequency_Hz;
  t.damping_ratio = damping;
  t.sample_rate_Hz = 500;
  t.noise_fraction = format == RecordingFormat::Raw ? 0.002 : 0.0;
  writeSyntheticRecording(makeWeightDropRecording(t, format), dir / ("w" + std::to_string(static_cast<int>(mass_kg * 10)) + ".csv"));
}

}  // namespace

TEST_CASE("weight-drop signatures give the ratios, force per weight and damping trend of the two weights", "[analysis]") {
  TempDir dir("signatures");
  std::filesystem::create_directories(dir / "m");
  std::filesystem::create_directories(dir / "s");
  // Measured: the load cell reads 8 % high at both weights, the deformation 5 % low; the light
  // weight rings at 5 Hz, the heavy one at 3.5 Hz (simulated 5.5 and 3.6 Hz); the measured damping
  // exceeds the simulated one by 0.01 at the light and 0.03 at the heavy weight.
  writeWeight(dir / "m", 0.5, 1.08 * 40, 0.95 * 0.4, 5.0, 0.03, RecordingFormat::Raw);
  writeWeight(dir / "m", 1.0, 1.08 * 80, 0.95 * 0.8, 3.5, 0.05, RecordingFormat::Raw);
  writeWeight(dir / "s", 0.5, 40, 0.4, 5.5, 0.02, RecordingFormat::Calibrated);
  writeWeight(dir / "s", 1.0, 80, 0.8, 3.6, 0.02, RecordingFormat::Calibrated);
  const ComparisonResult c = compare(readRecordings({dir / "m"}), readRecordings({dir / "s"}), AnalysisSettings{});
  const Signatures s = signaturesOf(c, SignatureSettings{});
  REQUIRE(s.weight_drops.size() == 2);
  const WeightDropSignature& light = s.weight_drops[0];
  const WeightDropSignature& heavy = s.weight_drops[1];
  CHECK(light.key.mass_kg == 0.5);
  // Tolerances: 0.2 % white noise on a 20 % tail of ~1500 samples leaves ~1e-4 on the steady values;
  // cycle estimates of a 0.2 %-noisy, few-cycle response are good to ~1 %.
  CHECK(light.force_ratio.value == Approx(1.08).epsilon(0.002));
  CHECK(heavy.deformation_ratio.value == Approx(0.95).epsilon(0.002));
  CHECK(heavy.force_per_weight_measured_N_per_kg == Approx(86.4).epsilon(0.002));
  CHECK(heavy.force_per_weight_simulated_N_per_kg == Approx(80.0).epsilon(0.001));  // tail still rings slightly
  CHECK(light.frequency_ratio.value == Approx(5.0 / 5.5).epsilon(0.01));
  CHECK(heavy.damping_difference.value == Approx(0.03).margin(0.004));
  REQUIRE(s.weight_relations.defined);
  CHECK(s.weight_relations.force_ratio_change == Approx(0).margin(0.003));
  CHECK(s.weight_relations.damping_difference_change == Approx(0.02).margin(0.006));
  const double expected_consistency = 0.5 * 0.95 * ((5.0 / 5.5) * (5.0 / 5.5) + (3.5 / 3.6) * (3.5 / 3.6));
  CHECK(s.weight_relations.stiffness_consistency == Approx(expected_consistency).epsilon(0.02));
  CHECK(toJson(s)["weight_drops"][1]["force_ratio"].get<double>() == Approx(1.08).epsilon(0.002));
}

TEST_CASE("soil-bin signatures give the bias per depth and its trend with depth", "[analysis]") {
  TempDir dir("soil_signatures");
  std::filesystem::create_directories(dir / "m");
  std::filesystem::create_directories(dir / "s");
  // Measured draught 20 N at 18 mm and 40 N at 42 mm; simulated 20 N and 30 N: a bias of 0 and
  // -25 %, i.e. -25 / 24 % per mm.
  for (auto [depth, measured, simulated] : {std::tuple{18.0, 20.0, 20.0}, std::tuple{42.0, 40.0, 30.0}}) {
    SoilBinTruth t;
    t.depth_mm = depth;
    t.force_N = measured;
    writeSyntheticRecording(makeSoilBinRecording(t, RecordingFormat::Raw), dir / "m" / ("d" + std::to_string(int(depth)) + ".csv"));
    t.force_N = simulated;
    t.noise_fraction = 0;
    writeSyntheticRecording(makeSoilBinRecording(t, RecordingFormat::Calibrated), dir / "s" / ("d" + std::to_string(int(depth)) + ".csv"));
  }
  const ComparisonResult c = compare(readRecordings({dir / "m"}), readRecordings({dir / "s"}), AnalysisSettings{});
  const Signatures s = signaturesOf(c, SignatureSettings{});
  REQUIRE(s.soil_bins.size() == 2);
  // The fluctuation averages out of the 400 mm window to well below 1 %.
  CHECK(s.soil_bins[0].force_bias_percent == Approx(0).margin(1.0));
  CHECK(s.soil_bins[1].force_bias_percent == Approx(-25).margin(1.0));
  REQUIRE(s.force_bias_per_depth_percent_per_mm);
  CHECK(*s.force_bias_per_depth_percent_per_mm == Approx(-25.0 / 24.0).margin(0.06));
  // Same wall shape on both sides: no end-rise difference; no noise on the simulated side.
  CHECK(s.soil_bins[1].end_rise_difference == Approx(0).margin(0.05));
  CHECK(s.soil_bins[1].fluctuation_ratio < 1.0);
}

TEST_CASE("stroke phases put a discrepancy at the end wall into the end of stroke, not the insertion or the window", "[analysis]") {
  TempDir dir("stroke_phases");
  std::filesystem::create_directories(dir / "m");
  std::filesystem::create_directories(dir / "s");
  // The same run on both sides, two repeats each, except that the simulated force rises toward the
  // end wall twice as steeply (wall gain 3 against 1.5 from 540 mm on).
  for (int repeat : {1, 2}) {
    SoilBinTruth t;
    t.repeat = repeat;
    t.seed = static_cast<std::uint64_t>(repeat);
    writeSyntheticRecording(makeSoilBinRecording(t, RecordingFormat::Raw), dir / "m" / ("r" + std::to_string(repeat) + ".csv"));
    t.wall_gain = 3.0;
    t.seed = static_cast<std::uint64_t>(10 + repeat);
    writeSyntheticRecording(makeSoilBinRecording(t, RecordingFormat::Calibrated), dir / "s" / ("r" + std::to_string(repeat) + ".csv"));
  }
  const AnalysisSettings settings;
  const auto phases = strokePhaseForces(compare(readRecordings({dir / "m"}), readRecordings({dir / "s"}), settings), settings.evaluation);
  REQUIRE(phases.size() == 3);
  const auto percent = [](const StrokePhaseForce& f) { return 100 * (f.simulated.mean_N - f.measured.mean_N) / f.measured.mean_N; };
  CHECK(phaseName(phases[0].phase) == "insertion");
  CHECK(phaseName(phases[2].phase) == "end of stroke");
  CHECK(std::abs(percent(phases[0])) < 2.0);
  CHECK(std::abs(percent(phases[1])) < 1.0);
  CHECK(percent(phases[2]) > 10.0);  // the 60 mm of steeper wall in the last 100 mm of the stroke
  for (const auto& f : phases) {
    CHECK(f.measured.runs == 2);
    CHECK(f.simulated.runs == 2);
    CHECK(f.measured.std_error_N.has_value());
  }
}
