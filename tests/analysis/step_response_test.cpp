// Calibration-weight response (Fig. 8) and the Section 3.1 correlation on synthetic responses with a
// known frequency and damping ratio.
#include "demfem/analysis/step_response.hpp"
#include "demfem/analysis/synthetic.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace demfem::analysis;

namespace {

struct Signals {
  std::vector<double> t, force, deformation;
};

Signals calibratedSignals(const WeightDropTruth& truth) {
  const SyntheticRecording rec = makeWeightDropRecording(truth, RecordingFormat::Calibrated);
  return {rec.columns[0], rec.columns[1], rec.columns[2]};
}

}  // namespace

TEST_CASE("steady value, frequency and damping ratio of a noisy weight drop are recovered", "[analysis]") {
  WeightDropTruth truth;  // 3 Hz damped, zeta 0.05, 50 Hz sampling, 0.3 % noise
  truth.seed = 9;
  const Signals s = calibratedSignals(truth);
  const StepResponse r = analyseStepResponse(s.t, s.deformation, StepResponseSettings{}, "synthetic deformation");
  // Steady value: tail mean; the residual oscillation there is < 0.2 % of y_ss.
  CHECK(r.steady_value == Approx(truth.deformation_mm).epsilon(0.005));
  // Frequency from zero crossings interpolated between samples: within 1 %.
  CHECK(r.frequency_mean_Hz == Approx(truth.frequency_Hz).epsilon(0.01));
  CHECK(r.cycle_frequencies_Hz.size() >= 5);
  // Damping from the decrement of peaks refined by parabolas (16 samples per period): within 10 %.
  CHECK(r.damping_ratio_mean == Approx(truth.damping_ratio).epsilon(0.10));
  CHECK(r.cycle_damping_ratios.size() >= 5);
  CHECK(r.damping_ratio_std < 0.5 * truth.damping_ratio);
  // The first local maximum is the first overshoot, half a damped period after the drop.
  CHECK(r.first_peak_time_s == Approx(truth.drop_time_s + 0.5 / truth.frequency_Hz).margin(0.01));
}

TEST_CASE("a falling response is analysed like a rising one", "[analysis]") {
  WeightDropTruth truth;
  truth.noise_fraction = 0.0;
  truth.force_N = -4.5;  // the load cell reads negative
  truth.damping_ratio = 0.08;
  truth.frequency_Hz = 2.0;
  const Signals s = calibratedSignals(truth);
  const StepResponse r = analyseStepResponse(s.t, s.force, StepResponseSettings{}, "synthetic force");
  CHECK(r.steady_value == Approx(truth.force_N).epsilon(0.002));
  CHECK(r.frequency_mean_Hz == Approx(truth.frequency_Hz).epsilon(0.005));
  CHECK(r.damping_ratio_mean == Approx(truth.damping_ratio).epsilon(0.05));
  CHECK(r.peak_values.front() < truth.force_N);  // overshoot goes further down
}

TEST_CASE("a response without enough cycles above the noise fails naming the signal", "[analysis]") {
  WeightDropTruth truth;
  truth.damping_ratio = 0.6;  // heavily damped: one small overshoot
  truth.noise_fraction = 0.0;
  const Signals s = calibratedSignals(truth);
  CHECK_THROWS_WITH(analyseStepResponse(s.t, s.force, StepResponseSettings{}, "run.csv: column 'force'"),
                    Catch::StartsWith("run.csv: column 'force': only"));
}

TEST_CASE("aligning first local maxima removes a time offset before correlating (Section 3.1)", "[analysis]") {
  WeightDropTruth measured_truth;
  measured_truth.seed = 21;
  WeightDropTruth simulated_truth = measured_truth;
  simulated_truth.sample_rate_Hz = 1000.0;
  simulated_truth.drop_time_s = 0.0;  // the simulation starts with the drop
  simulated_truth.noise_fraction = 0.0;
  const Signals m = calibratedSignals(measured_truth);
  const Signals sim = calibratedSignals(simulated_truth);
  const StepResponse rm = analyseStepResponse(m.t, m.deformation, StepResponseSettings{}, "measured");
  const StepResponse rs = analyseStepResponse(sim.t, sim.deformation, StepResponseSettings{}, "simulated");
  const AlignedCorrelation c = correlateAligned(m.t, m.deformation, rm.first_peak_time_s, sim.t, sim.deformation, rs.first_peak_time_s, "pair");
  CHECK(c.shift_s == Approx(measured_truth.drop_time_s).margin(0.01));
  // Same response, 0.3 % noise: correlation is limited only by the noise.
  CHECK(c.correlation > 0.995);
  // A different frequency decorrelates.
  WeightDropTruth other = simulated_truth;
  other.frequency_Hz = 4.5;
  const Signals o = calibratedSignals(other);
  const StepResponse ro = analyseStepResponse(o.t, o.deformation, StepResponseSettings{}, "other");
  const AlignedCorrelation worse = correlateAligned(m.t, m.deformation, rm.first_peak_time_s, o.t, o.deformation, ro.first_peak_time_s, "pair");
  CHECK(worse.correlation < c.correlation - 0.02);
}

TEST_CASE("the Pearson correlation of linearly related sequences is +-1", "[analysis]") {
  CHECK(pearsonCorrelation({1, 2, 3, 4}, {3, 5, 7, 9}) == Approx(1.0));
  CHECK(pearsonCorrelation({1, 2, 3, 4}, {4, 3, 2, 1}) == Approx(-1.0));
}
