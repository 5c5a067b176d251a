// Section 2.3 on synthetic soil-bin runs whose true start, end and means are known by construction.
#include "demfem/analysis/evaluation.hpp"
#include "demfem/analysis/synthetic.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

using namespace demfem::analysis;
using demfem::support::TempDir;

namespace {

Recording synthesise(const SoilBinTruth& truth, RecordingFormat format, const TempDir& dir, const std::string& name) {
  writeSyntheticRecording(makeSoilBinRecording(truth, format), dir / (name + ".csv"));
  return readRecording(dir / (name + ".csv"));
}

}  // namespace

TEST_CASE("Section 2.3 recovers the true start, end and window means of a noisy run", "[analysis]") {
  TempDir dir("eval-truth");
  SoilBinTruth truth;  // 50 Hz, 30 mm/s, 0.5 % noise, 5 % power-law fluctuation, DAQ offsets
  truth.seed = 7;
  const Recording rec = synthesise(truth, RecordingFormat::Raw, dir, "run");
  const EvaluatedRun run = evaluateSoilBinRun(rec, EvaluationSettings{});

  CHECK(run.section_2_3_applied);
  // Start: the 10 %/20 % line of a linear rise meets the initial value at the true start; noise on
  // the two crossings (slope 1.5 % of the rise per sample) moves it by well under one sample (0.02 s).
  CHECK(run.start_time_s == Approx(truth.start_time_s).margin(0.02));
  // End: the wall makes the force largest at the true end of the stroke. Near the end the wall adds
  // 3 % of the steady value per sample while the fluctuation (5 % rms, rough at the sample scale)
  // can peak a few samples earlier: 5 samples (0.1 s, 3 mm of the 600 mm stroke).
  CHECK(run.end_time_s == Approx(truth.endTime()).margin(0.1));
  // Initial deformation is the DAQ offset times the factor (noise averaged over 25 samples).
  CHECK(run.initial_deformation_mm == Approx(truth.deformation_offset_units * truth.deformation_factor_mm_per_unit).margin(0.01));
  // Displacement runs 0 .. stroke.
  CHECK(run.curve.displacement_mm.front() == Approx(0.0).margin(0.6));
  CHECK(run.curve.displacement_mm.back() == Approx(truth.stroke_mm));
  // Means over 100-500 mm: the steady values (the fluctuation, 5 % rms, averages to < 1 %).
  CHECK(run.window.force_N.mean == Approx(truth.force_N).epsilon(0.01));
  CHECK(run.window.deformation_mm.mean == Approx(truth.deformation_mm).epsilon(0.01));
  // Standard deviation: fluctuation (~5.3 % rms) and noise (0.5 %) of the steady value.
  CHECK(run.window.force_N.std_dev == Approx(0.053 * truth.force_N).epsilon(0.25));
  CHECK(run.window.force_N.samples == Approx(400.0 / truth.velocity_mm_s * truth.sample_rate_Hz).margin(2));
}

TEST_CASE("the end can be taken at the deformation maximum instead of the force maximum", "[analysis]") {
  TempDir dir("eval-end");
  SoilBinTruth truth;
  truth.seed = 3;
  const Recording rec = synthesise(truth, RecordingFormat::Raw, dir, "run");
  EvaluationSettings settings;
  settings.end_signal = EndSignal::Deformation;
  CHECK(evaluateSoilBinRun(rec, settings).end_time_s == Approx(truth.endTime()).margin(0.1));  // as above
}

TEST_CASE("a calibrated (simulated) run is taken as it is, with its tilt statistics", "[analysis]") {
  TempDir dir("eval-sim");
  SoilBinTruth truth;
  truth.sample_rate_Hz = 200.0;
  truth.seed = 11;
  const Recording rec = synthesise(truth, RecordingFormat::Calibrated, dir, "sim");
  const EvaluatedRun run = evaluateSoilBinRun(rec, EvaluationSettings{});
  CHECK_FALSE(run.section_2_3_applied);
  CHECK(run.curve.size() == rec.size());
  CHECK(run.window.force_N.mean == Approx(truth.force_N).epsilon(0.01));
  REQUIRE(run.window.tilt_deg);
  CHECK(run.window.tilt_deg->mean == Approx(truth.tilt_deg_per_mm * truth.deformation_mm).epsilon(0.01));
}

TEST_CASE("a run too short for the statistics window fails naming the file and the covered range", "[analysis]") {
  TempDir dir("eval-short");
  SoilBinTruth truth;
  truth.seed = 5;
  truth.stroke_mm = 90.0;  // ends before the 100 mm window begins
  truth.wall_start_mm = 70.0;
  const Recording rec = synthesise(truth, RecordingFormat::Raw, dir, "short");
  try {
    evaluateSoilBinRun(rec, EvaluationSettings{});
    FAIL("expected an error");
  } catch (const InputError& e) {
    const std::string message = e.what();
    CHECK_THAT(message, Catch::Contains((dir / "short.csv").string() + ": the run covers 0."));  // first sample just after the start
    CHECK_THAT(message, Catch::Contains("-90 mm of tool displacement but the statistics window is 100-500 mm"));
  }
}

TEST_CASE("a run that covers the window too sparsely fails naming the file", "[analysis]") {
  TempDir dir("eval-sparse");
  SoilBinTruth truth;
  truth.seed = 6;
  truth.sample_rate_Hz = 0.5;  // one sample every 60 mm of displacement
  truth.start_time_s = 0.0;
  truth.rest_after_s = 0.0;
  const Recording rec = synthesise(truth, RecordingFormat::Calibrated, dir, "sparse");
  CHECK_THROWS_WITH(evaluateSoilBinRun(rec, EvaluationSettings{}),
                    Catch::Contains((dir / "sparse.csv").string() + ": only 7 samples in the window 100-500 mm (need 10)"));
}

TEST_CASE("a run whose deformation never rises has no start", "[analysis]") {
  TempDir dir("eval-flat");
  SoilBinTruth truth;
  truth.deformation_mm = 0.0;
  truth.noise_fraction = 0.0;
  const Recording rec = synthesise(truth, RecordingFormat::Raw, dir, "flat");
  CHECK_THROWS_WITH(evaluateSoilBinRun(rec, EvaluationSettings{}), Catch::Contains("never rises clearly above its initial value"));
}

TEST_CASE("repeats are pooled: mean of the means and spread between repeats", "[analysis]") {
  TempDir dir("eval-pool");
  std::vector<EvaluatedRun> runs;
  const std::vector<double> steady_force = {18.0, 20.0, 22.0};
  for (int r = 0; r < 3; ++r) {
    SoilBinTruth truth;
    truth.repeat = r + 1;
    truth.seed = 100 + static_cast<std::uint64_t>(r);
    truth.force_N = steady_force[static_cast<std::size_t>(r)];
    runs.push_back(evaluateSoilBinRun(synthesise(truth, RecordingFormat::Raw, dir, std::to_string(r) + "_repeat"), EvaluationSettings{}));
  }
  const PooledCase pooled = poolRepeats({&runs[0], &runs[1], &runs[2]}, EvaluationSettings{});
  CHECK(pooled.repeats == std::vector<int>{1, 2, 3});
  const double mean_of_means = (runs[0].window.force_N.mean + runs[1].window.force_N.mean + runs[2].window.force_N.mean) / 3.0;
  CHECK(pooled.force_mean_N == Approx(mean_of_means).epsilon(1e-12));
  CHECK(pooled.force_mean_N == Approx(20.0).epsilon(0.01));
  // Sample standard deviation of 18, 20, 22 is 2 (each repeat mean within 1 %).
  REQUIRE(pooled.force_between_repeats_std_N);
  CHECK(*pooled.force_between_repeats_std_N == Approx(2.0).margin(0.3));
  CHECK(pooled.deformation_mean_mm == Approx(2.0).epsilon(0.01));
  // The mean curve spans the overlap and averages the repeats.
  REQUIRE(pooled.mean_curve.size() > 100);
  CHECK(pooled.mean_curve.displacement_mm.back() == Approx(600.0).margin(1.0));
}

TEST_CASE("interpolation clamps outside the range and is linear inside", "[analysis]") {
  const std::vector<double> x{0.0, 1.0, 3.0}, y{0.0, 2.0, 6.0};
  CHECK(interpolate(x, y, -1.0) == 0.0);
  CHECK(interpolate(x, y, 2.0) == Approx(4.0));
  CHECK(interpolate(x, y, 9.0) == 6.0);
}
