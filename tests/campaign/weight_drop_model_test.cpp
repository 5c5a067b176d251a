// campaign's modal weight-drop model against the direct integration of fem::simulateWeightDrop
// (Eq 5-10 on all reduced DOFs), at the reference modulus and after a rescaling of E.
#include "weight_drop_fixture.hpp"

#include "demfem/campaign/model.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace demfem;

namespace {

struct Difference {
  double force = 0, deformation = 0;  // largest |modal - direct| over the run, relative to the static value
};

Difference compareAt(campaign::WeightDropModel& model, double E_Pa, double alpha_s, double mass_kg,
                     const nlohmann::ordered_json& extension = {}, double added_mass_kg = 0) {
  nlohmann::ordered_json json = campaign::test::fixtureStudyJson();
  json["weight_drop"]["added_mass_kg"] = added_mass_kg;
  json["tools"][0]["fem"]["E_Pa"] = E_Pa;
  json["tools"][0]["fem"]["alpha_s"] = alpha_s;
  if (!extension.is_null()) json["tools"][0].merge_patch(extension);
  const analysis::CaseKey key{analysis::CaseKind::CalibrationWeight, "strip", 0, mass_kg};
  const study::Study study = campaign::caseStudy(json, campaign::test::fixtureStudyPath().string(), key);
  const analysis::Recording modal = model.run(study, key, {});
  const study::Tool& tool = study.tools.front();
  const fem::WeightDropResult direct = fem::simulateWeightDrop(fem::reduce(fem::buildFullModel(tool)), tool, *study.weight_drop, study.fem.dt_s);
  const std::size_t lead_in = 100;  // 0.1 s at rest before the weight is hung
  REQUIRE(modal.size() == direct.samples.size() + lead_in);
  Difference d;
  for (std::size_t i = 0; i < modal.size(); ++i) {
    if (i < lead_in) {
      CHECK(modal.force[i] == 0);
      CHECK(modal.deformation[i] == 0);
      continue;
    }
    const auto& s = direct.samples[i - lead_in];
    CHECK(modal.time_s[i] == Approx(s.t_s + 0.1));
    d.force = std::max(d.force, std::abs(modal.force[i] - s.force_N) / direct.static_force_N);
    d.deformation = std::max(d.deformation, std::abs(modal.deformation[i] - s.deformation_mm) / direct.static_deformation_mm);
  }
  return d;
}

}  // namespace

TEST_CASE("the modal weight-drop model reproduces the direct integration, also after E and alpha change", "[campaign]") {
  campaign::WeightDropModel model;
  const Difference reference = compareAt(model, 4.06e9, 5.5e-4, 0.05);
  const Difference rescaled = compareAt(model, 5.3e9, 1.2e-3, 0.05);  // the same basis, scaled
  CHECK(model.basesBuilt() == 2);  // one reduction and one weight's modes for both runs

  CHECK(reference.force < 2e-3);
  CHECK(reference.deformation < 2e-3);
  CHECK(rescaled.force < 2e-3);
  CHECK(rescaled.deformation < 2e-3);
}

TEST_CASE("the modal model reproduces the direct integration with a compliant clamp and sensor gains, one reduction for all", "[campaign]") {
  campaign::WeightDropModel model;
  const nlohmann::ordered_json soft = {{"constraints", {{"clamp_rotational_stiffness_Nm_per_rad", 0.5}}},
                                       {"sensors", {{"force_gain", 0.9}, {"deformation_gain", 1.1}}}};
  const nlohmann::ordered_json stiff = {{"constraints", {{"clamp_rotational_stiffness_Nm_per_rad", 20.0}}},
                                        {"sensors", {{"force_gain", 1.2}, {"deformation_gain", 0.8}}}};
  const Difference a = compareAt(model, 4.06e9, 5.5e-4, 0.05, soft);
  const Difference b = compareAt(model, 5.0e9, 5.5e-4, 0.05, stiff);  // new E and spring: the same reduction
  CHECK(model.basesBuilt() == 4);  // one reduction, one spring Ritz basis for the weight, one basis per (E, spring)
  CHECK(a.force < 2e-3);
  CHECK(a.deformation < 2e-3);
  CHECK(b.force < 2e-3);
  CHECK(b.deformation < 2e-3);
}

TEST_CASE("the modal model with an added mass on the pan (Ritz on the kept modes) reproduces the direct integration", "[campaign]") {
  campaign::WeightDropModel model;
  const Difference light = compareAt(model, 4.06e9, 5.5e-4, 0.05, {}, 0.01);
  const Difference heavy = compareAt(model, 4.06e9, 5.5e-4, 0.05, {}, 0.05);  // as heavy as the weight
  const Difference sprung = compareAt(model, 4.06e9, 5.5e-4, 0.05, {{"constraints", {{"clamp_rotational_stiffness_Nm_per_rad", 0.5}}}}, 0.03);
  CHECK(model.basesBuilt() == 5);  // two reductions (rigid, sprung), one weight's modes each, one spring Ritz basis
  for (const Difference& d : {light, heavy, sprung}) {
    CHECK(d.force < 2e-3);
    CHECK(d.deformation < 2e-3);
  }
}
