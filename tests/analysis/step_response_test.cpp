// Calibration-weight response (Fig. 8): fitted figures, cycle-by-cycle spread, and the Section 3.1
// correlation on synthetic responses with a known frequency and damping ratio.
#include "demfem/analysis/step_response.hpp"
#include "demfem/analysis/synthetic.hpp"
#include "calibrated_signals.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace demfem::analysis;

using test::calibratedSignals;
using test::Signals;

TEST_CASE("a noisy weight drop gives the fitted figures and their cycle-by-cycle spread (Fig. 8)", "[analysis]") {
  WeightDropTruth truth;  // 3 Hz damped, zeta 0.05, 50 Hz sampling, 0.3 % noise
  truth.seed = 9;
  const Signals s = calibratedSignals(truth);
  const StepResponse r = analyseStepResponse(s.t, s.deformation, StepResponseSettings{}, "synthetic deformation");
  CHECK(r.fit.steady == Approx(truth.deformation_mm).epsilon(0.002));
  CHECK(r.fit.frequency_Hz == Approx(truth.frequency_Hz).epsilon(0.005));
  CHECK(r.fit.damping_ratio == Approx(truth.damping_ratio).epsilon(0.05));
  // Cycles counted about the fitted steady value: zero crossings interpolated between samples (16
  // per period) give each period within 5 % and their mean within 1 %; their spread is what
  // Fig. 8's error segments show.
  REQUIRE(r.cycle_frequencies_Hz.size() >= 5);
  REQUIRE(r.cycle_damping_ratios.size() >= 5);
  double mean_Hz = 0.0;
  for (double f : r.cycle_frequencies_Hz) {
    CHECK(f == Approx(truth.frequency_Hz).epsilon(0.05));
    mean_Hz += f / static_cast<double>(r.cycle_frequencies_Hz.size());
  }
  CHECK(mean_Hz == Approx(truth.frequency_Hz).epsilon(0.01));
  CHECK(r.cycle_frequency_std_Hz > 0.0);
  CHECK(r.cycle_frequency_std_Hz < 0.03 * truth.frequency_Hz);
  CHECK(r.cycle_damping_ratio_std < 0.5 * truth.damping_ratio);
  // The first local maximum is the first overshoot, half a damped period after the drop.
  CHECK(r.first_peak_time_s == Approx(truth.drop_time_s + 0.5 / truth.frequency_Hz).margin(0.005));
  CHECK(r.peak_times_s.front() == Approx(r.first_peak_time_s).margin(0.01));
}

TEST_CASE("a 3 s record still ringing at half its first overshoot has cycles above the fit's noise band", "[analysis]") {
  // The tail's own standard deviation (the ringing) would put the band above every peak.
  WeightDropTruth truth;
  truth.duration_s = 3.0;
  truth.drop_time_s = 0.4;
  truth.frequency_Hz = 4.0;
  truth.damping_ratio = std::log(2.0) / (2.6 * 2.0 * M_PI * 4.0);
  truth.noise_fraction = 0.005;
  const Signals s = calibratedSignals(truth);
  const StepResponse r = analyseStepResponse(s.t, s.force, StepResponseSettings{}, "force");
  CHECK(r.fit.frequency_Hz == Approx(4.0).epsilon(0.005));
  // 2.6 s of ringing at 4 Hz: 11 upward crossings (10 periods) and 10 peaks (9 decrements), every
  // one counted.
  CHECK(r.cycle_frequencies_Hz.size() == 10);
  CHECK(r.cycle_damping_ratios.size() == 9);
}

TEST_CASE("a falling response is analysed like a rising one", "[analysis]") {
  WeightDropTruth truth;
  truth.noise_fraction = 0.0;
  truth.force_N = -4.5;  // the load cell reads negative
  truth.damping_ratio = 0.08;
  truth.frequency_Hz = 2.0;
  const Signals s = calibratedSignals(truth);
  const StepResponse r = analyseStepResponse(s.t, s.force, StepResponseSettings{}, "synthetic force");
  CHECK(r.fit.steady == Approx(truth.force_N).epsilon(1e-6));
  CHECK(r.fit.frequency_Hz == Approx(truth.frequency_Hz).epsilon(1e-6));
  CHECK(r.fit.damping_ratio == Approx(truth.damping_ratio).epsilon(1e-6));
  CHECK(r.peak_values.front() < truth.force_N);  // overshoot goes further down
}

TEST_CASE("a heavily damped response has its fit but no cycle spread", "[analysis]") {
  WeightDropTruth truth;
  truth.damping_ratio = 0.4;  // one overshoot of 25 %, the next 1.6 %
  truth.noise_fraction = 0.001;
  const Signals s = calibratedSignals(truth);
  const StepResponse r = analyseStepResponse(s.t, s.force, StepResponseSettings{}, "run.csv: column 'force'");
  CHECK(r.fit.damping_ratio == Approx(0.4).epsilon(0.02));
  CHECK(r.cycle_frequencies_Hz.size() < 2);
  CHECK(std::isnan(r.cycle_frequency_std_Hz));
}

TEST_CASE("a response that never overshoots fails naming the signal", "[analysis]") {
  std::vector<double> t, y;
  for (int i = 0; i < 200; ++i) {
    t.push_back(0.02 * i);
    y.push_back(4.5 * (1.0 - std::exp(-2.0 * t.back())));
  }
  CHECK_THROWS_WITH(analyseStepResponse(t, y, StepResponseSettings{}, "run.csv: column 'force'"),
                    Catch::StartsWith("run.csv: column 'force': the response never overshoots"));
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
