// Hidden-effect tests of the diagnosis (docs/diagnosis.md): calibration-weight recordings made by an
// independent Euler-Bernoulli beam model of the tool (the fixture of this folder, no code of the
// project's FEM) with one effect the diagnosis is not told about, written as raw DAQ recordings
// (quantised, noisy, with a resting baseline). The diagnosis must name the effect and its
// extension must cut the held-out error by at least 50 %; the beam with no effect (the project's
// plate model against another correct model of the same tool) must give "no significant
// discrepancy".
#include "beam_weight_drop.hpp"
#include "weight_drop_fixture.hpp"

#include "demfem/campaign/diagnose.hpp"
#include "demfem/study/study.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <fstream>

using namespace demfem;
using campaign::test::BeamTool;

namespace {

const std::filesystem::path kStudy = std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/narrow_weight_drop.json";

// The two weights of the narrow tool (a quarter of the paper's 0.5 kg and 1 kg for a quarter of
// its width), each recorded twice.
std::vector<analysis::Recording> beamRecordings(const BeamTool& beam, const std::filesystem::path& dir) {
  campaign::test::Daq daq;
  for (double mass : {0.125, 0.25})
    for (int repeat : {1, 2}) {
      const auto name = "w" + std::to_string(static_cast<int>(mass * 1000)) + "_r" + std::to_string(repeat) + ".csv";
      analysis::writeSyntheticRecording(campaign::test::beamRecording(beam, mass, daq, repeat), dir / name);
    }
  return analysis::readRecordings({dir});
}

campaign::Diagnosis diagnoseBeam(const BeamTool& beam, const std::string& name) {
  campaign::test::TempDir dir("diagnose-" + name);
  const auto recordings = beamRecordings(beam, dir.path());
  std::ifstream in(kStudy);
  const auto study = nlohmann::ordered_json::parse(in);
  const campaign::DiagnosisSettings settings;
  campaign::WeightDropModel model;
  campaign::Diagnosis d = campaign::diagnose(study, kStudy.string(), recordings, model, settings);
  INFO(campaign::toJson(d, settings, "extended_study.json").dump(1));
  CHECK_NOTHROW(study::parseStudy(d.extended_study.dump(), kStudy.string()));  // valid and runnable
  return d;
}

void requireNamed(const campaign::Diagnosis& d, const std::string& cause) {
  INFO("reason: " << d.reason);
  for (const auto& r : d.ranking)
    INFO(r.id << ": " << r.error_before_percent << " % -> " << r.error_after_percent << " % (" << r.split << "), dBIC " << r.delta_bic);
  REQUIRE(d.cause);
  CHECK(*d.cause == cause);
  CHECK(d.gain_percent >= 50.0);
  CHECK(d.ranking.front().held_out);
  CHECK(d.unjudged.empty());  // every weight cause is judged on every weight quantity
}

}  // namespace

TEST_CASE("weight drops of a beam with a compliant clamp are diagnosed as clamp_compliance", "[campaign][diagnose]") {
  BeamTool beam;
  beam.k_theta_Nm_per_rad = 1.5;  // about the narrow tool's own EI / L (1.35 N m/rad)
  const auto d = diagnoseBeam(beam, "clamp");
  requireNamed(d, "clamp_compliance");
}

TEST_CASE("weight drops of a beam with a 20 % lower Young's modulus are diagnosed as young_modulus", "[campaign][diagnose]") {
  BeamTool beam;
  beam.E_Pa *= 0.8;
  const auto d = diagnoseBeam(beam, "modulus");
  requireNamed(d, "young_modulus");
}

TEST_CASE("weight drops of a beam with mass-proportional damping are diagnosed as mass_damping", "[campaign][diagnose]") {
  BeamTool beam;
  beam.beta_per_s = 1.5;  // damping ratio +0.03 at the heavy weight's 3.6 Hz
  const auto d = diagnoseBeam(beam, "damping");
  requireNamed(d, "mass_damping");
}

TEST_CASE("weight drops read through a load cell 15 % low are diagnosed as sensor_gain", "[campaign][diagnose]") {
  BeamTool beam;
  beam.force_gain = 0.85;
  const auto d = diagnoseBeam(beam, "gain");
  requireNamed(d, "sensor_gain");
}

TEST_CASE("weight drops of a beam with no effect beyond noise give no significant discrepancy", "[campaign][diagnose]") {
  const auto d = diagnoseBeam(BeamTool{}, "null");
  INFO("reason: " << d.reason);
  CHECK_FALSE(d.cause);
  CHECK(d.baseline_error_percent < 5.0);
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
