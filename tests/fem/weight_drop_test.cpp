// Calibration-weight simulation (Section 2.10.1) and the Fig. 8 evaluation of its signals.
#include "fem_test_tools.hpp"

#include "demfem/fem/integrator.hpp"
#include "demfem/fem/weight_drop.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

using namespace demfem;
using namespace demfem::fem;

TEST_CASE("a sampled damped oscillation is characterized by its steady value, frequency and damping ratio", "[fem]") {
  // v = S + A exp(-zeta w t) cos(w_d t), 40 samples per period: closed-form references.
  const double S = 3.0, A = 1.5, f = 5.0, zeta = 0.03, dt = 1 / (40 * f);
  const double w = 2 * std::numbers::pi * f, wd = w * std::sqrt(1 - zeta * zeta);
  std::vector<double> v;
  for (int i = 0; i < 4000; ++i) v.push_back(S + A * std::exp(-zeta * w * i * dt) * std::cos(wd * i * dt));
  const SignalCharacteristics c = characterize(v, dt);
  CHECK(c.steady == Approx(S).epsilon(1e-4));  // the oscillation has decayed to 1e-6 A in the last third
  CHECK(c.frequency_Hz == Approx(wd / (2 * std::numbers::pi)).epsilon(1e-3));
  CHECK(c.damping_ratio == Approx(zeta).epsilon(5e-3));
  CHECK(c.maxima > 20);
}

TEST_CASE("the weight drop rings at the loaded tool's first frequency with its Rayleigh damping", "[fem]") {
  const study::Tool tool = testing::smallStrip();
  const ReducedModel model = reduce(buildPlateModel(tool));
  study::WeightDrop drop;
  drop.mass_kg = 0.05;
  drop.pan_rows_from_tip_m = 0.010;
  // The reference: the first mode of the model with the weight's mass lumped on the pan rows' z DOFs.
  ReducedModel loaded = model;
  std::vector<int> pan;
  for (int k = 0; k < model.keypointCount(); ++k)
    if (model.keypoints(k, 1) <= 0.010 + 1e-9) pan.push_back(3 * k + 2);
  addLumpedMass(loaded, pan, drop.mass_kg / static_cast<double>(pan.size()));
  const double f1 = naturalModes(loaded, 1).frequencies_Hz[0];
  const double omega = 2 * std::numbers::pi * f1;
  study::Tool damped = tool;
  damped.fem.alpha_s = 2 * 0.02 / omega;  // zeta(mode 1) = alpha w / 2 = 0.02
  damped.fem.beta_per_s = 0;
  const double dt = 1 / (50 * f1);
  drop.duration_s = 60 / f1;
  const WeightDropResult r = simulateWeightDrop(model, damped, drop, dt);
  CHECK(r.pan_keypoints == static_cast<int>(pan.size()));
  CHECK(r.samples.size() == static_cast<std::size_t>(std::llround(drop.duration_s / dt)) + 1);
  // Frequency: the scheme's discrete frequency of mode 1 (period elongation included), 1 %.
  const double expected_Hz = predictedDiscreteFrequency(omega, dt) / (2 * std::numbers::pi);
  CHECK(r.deformation.frequency_Hz == Approx(expected_Hz).epsilon(0.01));
  CHECK(r.force.frequency_Hz == Approx(expected_Hz).epsilon(0.01));
  // Damping: the Rayleigh ratio of mode 1 within 3 % (higher modes ride on the first maxima).
  CHECK(r.deformation.damping_ratio == Approx(0.02).epsilon(0.03));
  // Steady values settle on the static solution under the weight (1 % after 60 periods).
  CHECK(r.deformation.steady == Approx(r.static_deformation_mm).epsilon(0.01));
  CHECK(r.force.steady == Approx(r.static_force_N).epsilon(0.01));
  CHECK(r.static_force_N > drop.mass_kg * kStandardGravity_m_s2);  // the load cell sits between weight and clamp
}
