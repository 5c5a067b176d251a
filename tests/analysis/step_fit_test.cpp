// The damped step-response fit on calibration-weight records of the paper's length (3 s, Fig. 5c)
// and on long ones, against records generated in closed form (synthetic.hpp) with white noise.
#include "demfem/analysis/step_fit.hpp"
#include "demfem/analysis/synthetic.hpp"
#include "calibrated_signals.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace demfem::analysis;

namespace {

using test::calibratedSignals;
using test::Signals;

// A 3 s record whose tail still rings at about half the first overshoot: zeta w_n 3 s = ln 2.
WeightDropTruth threeSecondRecord(double frequency_Hz, double sample_rate_Hz, std::uint64_t seed) {
  WeightDropTruth truth;
  truth.duration_s = 3.0;
  truth.drop_time_s = 0.4;
  truth.frequency_Hz = frequency_Hz;
  truth.damping_ratio = std::log(2.0) / (2.6 * 2.0 * M_PI * frequency_Hz);
  truth.sample_rate_Hz = sample_rate_Hz;
  truth.noise_fraction = 0.005;
  truth.seed = seed;
  return truth;
}

}  // namespace

TEST_CASE("a 3 s weight-drop record that still rings gives steady value, frequency and damping from the fit", "[analysis]") {
  // PMMA-like frequencies, the DAQ's 50 Hz and a simulation's 1 kHz sampling, three noise seeds.
  for (const double frequency_Hz : {2.5, 4.0, 6.0})
    for (const double rate_Hz : {50.0, 1000.0})
      for (const std::uint64_t seed : {1u, 2u, 3u}) {
        const WeightDropTruth truth = threeSecondRecord(frequency_Hz, rate_Hz, seed);
        const Signals r = calibratedSignals(truth);
        INFO("f " << frequency_Hz << " Hz, " << rate_Hz << " Hz sampling, seed " << seed << ", zeta " << truth.damping_ratio);
        const StepResponseFit fit = fitStepResponse(r.t, r.deformation, "deformation");
        CHECK(fit.frequency_Hz == Approx(truth.frequency_Hz).epsilon(0.005));
        CHECK(fit.damping_ratio == Approx(truth.damping_ratio).epsilon(0.05));
        CHECK(fit.steady == Approx(truth.deformation_mm).epsilon(0.002));
        CHECK(fit.initial == Approx(0.0).margin(0.002 * truth.deformation_mm));
        CHECK(fit.step_time_s == Approx(truth.drop_time_s).margin(0.1 / rate_Hz + 0.002));
        // The residual is the added noise: 0.5 % of the steady value (within 15 % for >= 150 samples).
        CHECK(fit.residual_rms == Approx(truth.noise_fraction * truth.deformation_mm).epsilon(0.15));
        CHECK(fit.natural_frequency_Hz == Approx(fit.frequency_Hz / std::sqrt(1 - fit.damping_ratio * fit.damping_ratio)).epsilon(1e-12));
      }
}

TEST_CASE("the fit's standard errors cover the scatter of the estimates over noise seeds", "[analysis]") {
  // 40 noisy realisations of one record: the error the fit states for one record is the spread of
  // the estimates across realisations (within 40 %, the sampling error of a 40-sample spread).
  std::vector<double> frequencies;
  double stated = 0.0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    WeightDropTruth truth = threeSecondRecord(4.0, 50.0, seed);
    truth.noise_fraction = 0.02;
    const Signals r = calibratedSignals(truth);
    const StepResponseFit fit = fitStepResponse(r.t, r.force, "force");
    frequencies.push_back(fit.frequency_Hz);
    stated += fit.frequency_error_Hz / 40.0;
  }
  double mean = 0.0, spread = 0.0;
  for (double f : frequencies) mean += f / 40.0;
  for (double f : frequencies) spread += (f - mean) * (f - mean) / 39.0;
  CHECK(std::sqrt(spread) == Approx(stated).epsilon(0.4));
  CHECK(mean == Approx(4.0).epsilon(0.001));
}

TEST_CASE("15 s weight-drop records with 0.5 % noise give the frequency within 0.5 % at every mass", "[analysis]") {
  // Lighter weights ring faster and longer (0.5 kg: 5.5 Hz, lightly damped), as in Fig. 8.
  struct Case {
    double mass_kg, frequency_Hz, damping_ratio;
  };
  for (const Case c : {Case{0.5, 5.5, 0.012}, Case{1.0, 4.0, 0.02}, Case{2.0, 2.9, 0.035}})
    for (const std::uint64_t seed : {4u, 5u}) {
      WeightDropTruth truth;
      truth.mass_kg = c.mass_kg;
      truth.duration_s = 15.0;
      truth.drop_time_s = 1.0;
      truth.frequency_Hz = c.frequency_Hz;
      truth.damping_ratio = c.damping_ratio;
      truth.noise_fraction = 0.005;
      truth.seed = seed;
      const Signals r = calibratedSignals(truth);
      const StepResponseFit fit = fitStepResponse(r.t, r.force, "force");
      INFO(c.mass_kg << " kg, seed " << seed);
      CHECK(fit.frequency_Hz == Approx(truth.frequency_Hz).epsilon(0.005));
      CHECK(fit.damping_ratio == Approx(truth.damping_ratio).epsilon(0.05));
      CHECK(fit.steady == Approx(truth.force_N).epsilon(0.002));
    }
}

TEST_CASE("a falling step is fitted like a rising one", "[analysis]") {
  WeightDropTruth truth = threeSecondRecord(3.0, 200.0, 7);
  truth.force_N = -4.5;  // the load cell reads negative
  const Signals r = calibratedSignals(truth);
  const StepResponseFit fit = fitStepResponse(r.t, r.force, "force");
  CHECK(fit.steady == Approx(truth.force_N).epsilon(0.002));
  CHECK(fit.frequency_Hz == Approx(truth.frequency_Hz).epsilon(0.005));
  CHECK(fit.damping_ratio == Approx(truth.damping_ratio).epsilon(0.05));
  CHECK(fit.at(truth.drop_time_s - 0.1) == Approx(fit.initial));
}

TEST_CASE("records without a step or without an overshoot are rejected naming the signal", "[analysis]") {
  std::vector<double> t, flat, creep;
  for (int i = 0; i < 100; ++i) {
    t.push_back(0.1 * i);
    flat.push_back(2.0);
    creep.push_back(1.0 - std::exp(-t.back()));  // first order: no overshoot
  }
  CHECK_THROWS_WITH(fitStepResponse(t, flat, "run.csv: column 'force_N'"), Catch::StartsWith("run.csv: column 'force_N': the signal does not step"));
  CHECK_THROWS_WITH(fitStepResponse(t, creep, "run.csv: column 'force_N'"), Catch::Contains("never overshoots"));
  CHECK_THROWS_WITH(fitStepResponse({0.0, 1.0}, {0.0, 1.0}, "x"), Catch::Contains("at least 20"));
}
