// Hidden-effect tests of the diagnosis (docs/diagnosis.md): calibration-weight recordings made by an
// independent Euler-Bernoulli beam model of the tool (the fixture of this folder, no code of the
// project's FEM) with one effect the diagnosis is not told about, written as raw DAQ recordings
// (quantised, noisy, with a resting baseline). The diagnosis must name the effect and its
// extension must beat the calibrated baseline on held-out weights; the beam with no effect (the
// project's plate model against another correct model of the same tool) must give "no significant
// discrepancy", and an effect outside the catalogue "unexplained discrepancy".
#include "beam_weight_drop.hpp"
#include "weight_drop_fixture.hpp"

#include "demfem/campaign/diagnose.hpp"
#include "demfem/study/study.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>

using namespace demfem;
using campaign::test::BeamTool;

namespace {

const std::filesystem::path kStudy = std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/narrow_weight_drop.json";

// The beam standing in for the narrow plate tool: an Euler-Bernoulli beam is softer than the 3D
// plate with its clamp, which the diagnosis of the beam's null measures as a calibrated E_Pa 1.89 %
// above the study's (9.8 standard errors, 2026-12-08); the stand-in's modulus carries that factor so
// that its null is the plate's null in stiffness (docs/diagnosis.md, "Hidden-effect tests").
BeamTool plateBeam() {
  BeamTool beam;
  beam.E_Pa /= 1.0189;
  return beam;
}

// A change of the recorded channels after the DAQ (a test-local effect outside the catalogue).
using ChannelEffect = std::function<void(analysis::SyntheticRecording&)>;

// The two weights of the narrow tool (a quarter of the paper's 0.5 kg and 1 kg for a quarter of
// its width), each recorded twice.
std::vector<analysis::Recording> beamRecordings(const BeamTool& beam, const std::filesystem::path& dir, const ChannelEffect& effect) {
  campaign::test::Daq daq;
  for (double mass : {0.125, 0.25})
    for (int repeat : {1, 2}) {
      const auto name = "w" + std::to_string(static_cast<int>(mass * 1000)) + "_r" + std::to_string(repeat) + ".csv";
      analysis::SyntheticRecording rec = campaign::test::beamRecording(beam, mass, daq, repeat);
      if (effect) effect(rec);
      analysis::writeSyntheticRecording(rec, dir / name);
    }
  return analysis::readRecordings({dir});
}

campaign::Diagnosis diagnoseBeam(const BeamTool& beam, const std::string& name, const ChannelEffect& effect = {}) {
  campaign::test::TempDir dir("diagnose-" + name);
  const auto recordings = beamRecordings(beam, dir.path(), effect);
  std::ifstream in(kStudy);
  const auto study = nlohmann::ordered_json::parse(in);
  const campaign::DiagnosisSettings settings;
  campaign::WeightDropModel model;
  campaign::Diagnosis d = campaign::diagnose(study, kStudy.string(), recordings, model, settings);
  INFO(campaign::toJson(d, settings, "extended_study.json").dump(1));
  CHECK_NOTHROW(study::parseStudy(d.extended_study.dump(), kStudy.string()));  // valid and runnable
  double probability = d.baseline.probability;
  for (const auto& m : d.models) probability += m.probability;
  CHECK(probability == Approx(1.0).epsilon(1e-9));
  std::printf("diagnose %s: %s", name.c_str(), campaign::verdictText(d.verdict).c_str());
  for (const auto& c : d.causes) std::printf(" %s", c.c_str());
  std::printf(" (gain %.3g %%, %.2f s): %s\n", d.gain_percent, d.wall_time_s, d.reason.c_str());
  return d;
}

// The named model must be `causes` (in any order); held out (when `held_out`), its held-out chi2 cut
// by at least min_chi2_gain_percent.
void requireNamed(const campaign::Diagnosis& d, std::vector<std::string> causes, bool held_out, double min_chi2_gain_percent) {
  INFO("reason: " << d.reason);
  for (const auto& m : d.models)
    INFO(m.id() << ": ln B " << m.ln_bayes_factor << ", p " << m.probability << ", significant " << m.significant << ", "
                << m.error_before_percent << " % -> " << m.error_after_percent << " % (" << m.split << ")");
  REQUIRE(d.verdict == campaign::Verdict::Cause);
  std::vector<std::string> named = d.causes;
  std::sort(named.begin(), named.end());
  std::sort(causes.begin(), causes.end());
  CHECK(named == causes);
  REQUIRE(d.named_model);
  const auto model = d.models.begin() + static_cast<std::ptrdiff_t>(*d.named_model);
  CHECK(model->heldOut() == held_out);
  if (held_out) CHECK(model->chi2_gain_percent >= min_chi2_gain_percent);
  CHECK(d.unjudged.empty());  // every weight cause is judged on every weight quantity
}

}  // namespace

TEST_CASE("weight drops of a beam with a compliant clamp are diagnosed as clamp_compliance", "[campaign][diagnose]") {
  BeamTool beam = plateBeam();
  beam.k_theta_Nm_per_rad = 1.5;  // about the narrow tool's own EI / L (1.35 N m/rad)
  const auto d = diagnoseBeam(beam, "clamp");
  requireNamed(d, {"clamp_compliance"}, true, 90.0);
}

TEST_CASE("weight drops of a beam with a 20 % lower Young's modulus are diagnosed as young_modulus", "[campaign][diagnose]") {
  BeamTool beam = plateBeam();
  beam.E_Pa *= 0.8;
  const auto d = diagnoseBeam(beam, "modulus");
  requireNamed(d, {"young_modulus"}, true, 90.0);
}

TEST_CASE("weight drops of a beam with a 3 % lower Young's modulus name young_modulus by the calibration's shift", "[campaign][diagnose]") {
  // Inside the calibrated baseline's range (E known to 10 %): no residual is left, the baseline's
  // E_Pa moves by the hidden 3 %, far beyond its standard error, and that shift names the cause.
  BeamTool beam = plateBeam();
  beam.E_Pa *= 0.97;
  const auto d = diagnoseBeam(beam, "modulus-shift");
  INFO("reason: " << d.reason);
  REQUIRE(d.verdict == campaign::Verdict::Cause);
  CHECK(d.causes == std::vector<std::string>{"young_modulus"});
  CHECK_FALSE(d.named_model);
  const auto e = std::find_if(d.shifts.begin(), d.shifts.end(), [](const campaign::CalibrationShift& s) { return s.cause == "young_modulus"; });
  REQUIRE(e != d.shifts.end());
  CHECK(e->significant);
  CHECK(e->shift_percent == Approx(-3.0).margin(0.3));  // the model-form tolerance's share of E, 0.3 %
}

TEST_CASE("weight drops of a beam with mass-proportional damping are diagnosed as mass_damping", "[campaign][diagnose]") {
  BeamTool beam = plateBeam();
  beam.beta_per_s = 1.5;  // damping ratio +0.03 at the heavy weight's 3.6 Hz
  const auto d = diagnoseBeam(beam, "damping");
  requireNamed(d, {"mass_damping"}, false, 0.0);  // two damping terms: one weight cannot identify them
}

TEST_CASE("weight drops read through a load cell 15 % low are diagnosed as force_sensor_gain", "[campaign][diagnose]") {
  BeamTool beam = plateBeam();
  beam.force_gain = 0.85;
  const auto d = diagnoseBeam(beam, "gain");
  requireNamed(d, {"force_sensor_gain"}, true, 90.0);
}

TEST_CASE("weight drops read through a deformation sensor 5 % high are diagnosed as deformation_sensor_gain", "[campaign][diagnose]") {
  BeamTool beam = plateBeam();
  beam.deformation_gain = 1.05;  // one channel, a few percent: diluted below 5 % by the old RMS rule
  const auto d = diagnoseBeam(beam, "deformation-gain");
  requireNamed(d, {"deformation_sensor_gain"}, true, 50.0);
}

TEST_CASE("weight drops of a beam whose damping has another form are diagnosed as damping_form", "[campaign][diagnose]") {
  // A tenth of the nominal stiffness term and the mass term that keeps the heavy weight's damping
  // ratio: right at 0.25 kg, off at 0.125 kg (zeta = alpha omega / 2 + beta / 2 omega, Eq 4).
  BeamTool beam = plateBeam();
  const double heavy_omega = 2 * M_PI * 3.6;
  beam.beta_per_s = 0.9 * beam.alpha_s * heavy_omega * heavy_omega;
  beam.alpha_s *= 0.1;
  const auto d = diagnoseBeam(beam, "damping-form");
  requireNamed(d, {"damping_form"}, false, 0.0);
}

TEST_CASE("weight drops of a beam 15 % softer read through a load cell 10 % low name both causes", "[campaign][diagnose]") {
  BeamTool beam = plateBeam();
  beam.E_Pa *= 0.85;
  beam.force_gain = 0.9;
  const auto d = diagnoseBeam(beam, "pair");
  requireNamed(d, {"young_modulus", "force_sensor_gain"}, true, 90.0);
}

TEST_CASE("weight drops through a nonlinear deformation sensor are an unexplained discrepancy, no cause named", "[campaign][diagnose]") {
  // Outside the catalogue: the deformation reading grows with the square of the deflection (8 % at
  // 1 mm), which no linear model reproduces at two weights at once.
  const ChannelEffect nonlinear = [](analysis::SyntheticRecording& rec) {
    const campaign::test::Daq daq;
    for (double& units : rec.columns[2]) {
      const double mm = units * daq.deformation_factor_mm_per_unit;
      units = std::round(mm * (1 + 0.08 * mm) / daq.deformation_factor_mm_per_unit);
    }
  };
  const auto d = diagnoseBeam(plateBeam(), "nonlinear", nonlinear);
  INFO("reason: " << d.reason);
  CHECK(d.verdict == campaign::Verdict::UnexplainedDiscrepancy);
  CHECK(d.causes.empty());
  CHECK(d.reason.find("step_deformation_mm") != std::string::npos);
}

TEST_CASE("weight drops of a beam with no effect beyond noise give no significant discrepancy", "[campaign][diagnose]") {
  const auto d = diagnoseBeam(plateBeam(), "null");
  INFO("reason: " << d.reason);
  CHECK(d.verdict == campaign::Verdict::NoSignificantDiscrepancy);
  CHECK(d.causes.empty());
  for (const auto& l : d.localisation) CHECK_FALSE(l.significant);
}

TEST_CASE("each cause is judged on quantities of the objective: the weight causes on all, the soil causes on the window means",
          "[campaign][diagnose]") {
  const auto& names = campaign::quantityNames();
  for (const campaign::Cause& c : campaign::causeCatalogue()) {
    INFO(c.id);
    for (const std::string& q : c.judged_on) CHECK(std::find(names.begin(), names.end(), q) != names.end());
    if (c.domain == analysis::CaseKind::CalibrationWeight) CHECK(c.judged_on.empty());
    if (c.domain == analysis::CaseKind::SoilBin)
      CHECK(c.judged_on == std::vector<std::string>{"window_mean_force_N", "window_mean_deformation_mm"});
  }
}
