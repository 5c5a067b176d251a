// The CalculiX generator of weight-drop recordings (calculix_weight_drop.hpp; docs/diagnosis.md,
// "Recovery matrix") against beam theory on a slender strip, and its null recording against its own
// static solution. Runs ccx (Debian calculix-ccx) a few times, under a second each.
#include "beam_weight_drop.hpp"
#include "calculix_weight_drop.hpp"

#include "demfem/analysis/step_fit.hpp"

#include <catch2/catch.hpp>

#include <numbers>

using namespace demfem;
using namespace demfem::campaign::test;

namespace {

// A slender strip 400 x 10 x 4 mm, clamped over its top 40 mm, the load cell 120 mm below the clamp
// edge (a), the tip 360 mm below it (L), the weight on the tip row, the deformation read there.
CalculixTool slenderStrip() {
  CalculixTool t;
  t.length_m = 0.400, t.clamp_length_m = 0.040, t.load_cell_from_top_m = 0.160, t.sensor_from_top_m = 0.400;
  t.pan_rows_from_tip_m = 0.0;
  return t;
}

}  // namespace

TEST_CASE("the CalculiX generator's static load-cell force and tip deflection follow the propped cantilever", "[campaign][calculix]") {
  // Clamped at the edge, propped at a, a tip load P at L: the overhang's moment P (L - a) at the prop
  // carries over half to the clamp, so the prop holds R = P (1 + 3 (L - a) / (2 a)); the tip
  // deflects by the prop's rotation P (L - a) a / (4 EI) times L - a plus the overhang's own
  // P (L - a)^3 / (3 EI). Beam theory with EI = E W T^3 / 12: within 1 % (the 3D clamp, shear and
  // the width's anticlastic bending; measured -0.38 % and -0.016 %).
  const CalculixTool t = slenderStrip();
  const CalculixModes m = calculixModes(t, 0.05);
  const double a = 0.120, L = 0.360, EI = t.E_Pa * t.width_m * std::pow(t.thickness_m, 3) / 12;
  const double reaction = 1 + 3 * (L - a) / (2 * a);
  const double deflection_mm = 1000 * ((L - a) * (L - a) * a / (4 * EI) + std::pow(L - a, 3) / (3 * EI));
  CHECK(m.static_reaction_uniform == Approx(reaction).epsilon(0.01));
  CHECK(m.static_sensor_uniform_mm == Approx(deflection_mm).epsilon(0.01));
}

TEST_CASE("the CalculiX generator's first frequency follows the Euler-Bernoulli beam of the same strip", "[campaign][calculix]") {
  // The beam of beam_weight_drop.hpp (Hermite elements of 2.5 mm, converged), the same 0.05 kg on
  // the tip: within 1 % (measured +0.008 %).
  const CalculixTool t = slenderStrip();
  BeamTool beam;
  beam.free_length_m = 0.360, beam.prop_from_edge_m = 0.120, beam.sensor_from_edge_m = 0.360;
  beam.pan_length_m = 0.0, beam.element_m = 0.0025;
  const double beam_Hz = std::sqrt(beamModes(beam, 0.05).omega2(0)) / (2 * std::numbers::pi);
  const double calculix_Hz = std::sqrt(calculixModes(t, 0.05).omega2(0)) / (2 * std::numbers::pi);
  CHECK(calculix_Hz == Approx(beam_Hz).epsilon(0.01));
}

TEST_CASE("the CalculiX generator's clamp spring is the rigid clamp when stiff and beam theory's root spring when soft", "[campaign][calculix]") {
  // A spring of 1e7 EI/L: the rigid clamp's load-cell force and tip deflection within 1e-5. A spring
  // of 10 EI/L (L the free length): the load-cell force, tip deflection and first frequency of the
  // beam of beam_weight_drop.hpp with that root spring within 1 % (measured -0.13 %, -0.12 %, +0.06 %).
  const CalculixTool rigid = slenderStrip();
  const CalculixModes r = calculixModes(rigid, 0.05);
  CalculixTool stiff = rigid, soft = rigid;
  stiff.k_theta_Nm_per_rad = 1e7 * rigid.freeEIoverL(), soft.k_theta_Nm_per_rad = 10 * rigid.freeEIoverL();
  const CalculixModes s = calculixModes(stiff, 0.05);
  CHECK(s.static_reaction_uniform == Approx(r.static_reaction_uniform).epsilon(1e-5));
  CHECK(s.static_sensor_uniform_mm == Approx(r.static_sensor_uniform_mm).epsilon(1e-5));
  BeamTool beam;
  beam.free_length_m = 0.360, beam.prop_from_edge_m = 0.120, beam.sensor_from_edge_m = 0.360;
  beam.pan_length_m = 0.0, beam.element_m = 0.0025, beam.k_theta_Nm_per_rad = soft.k_theta_Nm_per_rad;
  const double load = 0.05 * kStandardGravity_m_s2;
  const ChannelResponse beam_static = beamWeightDrop(beam, 0.05, {1e5});
  const CalculixModes c = calculixModes(soft, 0.05);
  CHECK(c.static_reaction_uniform == Approx(beam_static.force_N[0] / load).epsilon(0.01));
  CHECK(c.static_sensor_uniform_mm == Approx(beam_static.deformation_mm[0] / load).epsilon(0.01));
  CHECK(std::sqrt(c.omega2(0)) == Approx(std::sqrt(beamModes(beam, 0.05).omega2(0))).epsilon(0.01));
}

TEST_CASE("the CalculiX generator's null recording steps to its static solution", "[campaign][calculix]") {
  // The narrow test tool (tests/campaign/data/narrow_weight_drop.json) with 0.25 kg: the step fits of
  // docs/analysis.md on the raw recording (tared: zero before the weight), read in N and mm, find the
  // static load-cell force and deformation as their asymptotes within 1e-4 (measured 3e-5 and 1e-5:
  // the one-mode fit of a record that also carries the higher modes; the DAQ noise makes the fits'
  // standard errors 3e-6 and 5e-6), the first mode's damped frequency within 1e-5 and its damping
  // ratio (Eq 4) within 1e-3 (measured 2.4e-4), far inside the recordings' 0.1 % noise floor.
  const CalculixTool t = calculixToolFromStudy(std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/narrow_weight_drop.json");
  const double mass = 0.25, load = mass * kStandardGravity_m_s2;
  const CalculixModes m = calculixModes(t, mass);
  const Daq daq;
  const analysis::SyntheticRecording rec = calculixRecording(t, mass, daq);
  std::vector<double> force, deformation;
  for (std::size_t i = 0; i < rec.columns[0].size(); ++i)
    force.push_back(rec.columns[1][i] * daq.force_factor_N_per_unit), deformation.push_back(rec.columns[2][i] * daq.deformation_factor_mm_per_unit);
  const auto f = analysis::fitStepResponse(rec.columns[0], force, "force");
  const auto d = analysis::fitStepResponse(rec.columns[0], deformation, "deformation");
  CHECK(f.steady == Approx(load * m.static_reaction_uniform).epsilon(1e-4));
  CHECK(d.steady == Approx(load * m.static_sensor_uniform_mm).epsilon(1e-4));
  const double w = std::sqrt(m.omega2(0)), zeta = t.dampingRatio(w);
  CHECK(d.frequency_Hz == Approx(w * std::sqrt(1 - zeta * zeta) / (2 * std::numbers::pi)).epsilon(1e-5));
  CHECK(d.damping_ratio == Approx(zeta).epsilon(1e-3));
}
