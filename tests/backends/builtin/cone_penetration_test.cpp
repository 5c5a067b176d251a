// Cone penetration on a small settled bin through the builtin DEM (Section 2.10.3, Fig. 10's finding):
// the resistance grows with depth, and a soil whose deeper layer has Table 4's higher friction resists
// more at depth than the same packing with the top layer's friction throughout. As in the paper (the
// non-layered assembly is the layered one with layer1's friction), both soils hold the particles of
// one deposition, shared as campaign/model.hpp shares a packing: the comparison is the friction's
// alone. The packing is the non-layered soil's: the layered soil's own deposition, rained with the
// deep layer's friction, stands in the insertion lattice's columns (docs/analysis.md, "Cone
// penetration").
#include "demfem/adapter/cone_drive.hpp"
#include "demfem/analysis/cone_penetration.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/campaign/model.hpp"
#include "support/study_in_code.hpp"

#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <numbers>

using namespace demfem;

namespace {

// An 80 x 200 mm bin with 60 mm of soil, three 5 cm^2 60 deg cones 50 mm apart pushed to 40 mm at
// 20 mm/s (twice the paper's 10 mm/s to halve the test's cost; the force is recorded every 0.04 mm).
study::Study coneStudy(bool layered) {
  study::Study s = support::binStudy(layered ? "cpt-small-layered" : "cpt-small-unlayered", study::StudyKind::ConePenetration, 0.2,
                                     0.08, 0.06);
  auto& soil = s.soil;
  support::useTopAndDeepLayers(soil, 0.02);
  const double deep_friction = layered ? 0.3 : 0.07, deep_rolling = layered ? 0.2 : 0.02;  // Table 4: layer4 against layer1
  soil.interactions = {{"top", "top", 0.6, 0.07, 0.02, 3e4},
                       {"top", "deep", 0.6, 0.07, 0.02, 3e4},
                       {"deep", "deep", 0.6, deep_friction, deep_rolling, 3e4},
                       {"top", "steel", 0.6, 0.3, 0.02, 0},
                       {"deep", "steel", 0.6, 0.3, deep_rolling, 0}};
  soil.settle_kinetic_energy_J = 1e-5;
  for (int c = 0; c < 3; ++c) {
    study::Tool cone;
    cone.name = "cone" + std::to_string(c + 1);
    cone.dem_material = "steel";
    support::usePaperCone(cone, 0.08);
    cone.motion.depth_m = 0.04;
    cone.motion.velocity_m_s = 0.02;
    cone.motion.start_z_m = 0.05 + 0.05 * c;
    cone.motion.center_x_m = 0.04;
    s.tools.push_back(cone);
  }
  support::useBuiltinStep(s, 0.002);
  return s;
}

analysis::CprSummary penetrate(const study::Study& study) {
  const auto dem = builtin::makeBackend(study);
  std::vector<analysis::CprProfile> cones;
  for (const auto& r : adapter::pushCones(*dem, study)) {
    analysis::CprProfile p{r.name, {}, {}};
    for (std::size_t k = 0; k < r.time_s.size(); ++k)
      if (r.tip_depth_m[k] > 0) {
        p.depth_m.push_back(r.tip_depth_m[k]);
        p.cpr_Pa.push_back(analysis::coneResistance_Pa(r.force_N[k], r.area_m2));
      }
    cones.push_back(p);
  }
  return analysis::summarize(study.name, cones, 0.005);
}

double meanBetween(const analysis::CprSummary& s, double from_m, double to_m) {
  double sum = 0;
  int n = 0;
  for (std::size_t k = 0; k < s.depth_m.size(); ++k)
    if (s.depth_m[k] >= from_m - 1e-9 && s.depth_m[k] <= to_m + 1e-9) {
      sum += s.mean_Pa[k];
      ++n;
    }
  REQUIRE(n > 0);
  return sum / n;
}

}  // namespace

TEST_CASE("CPR of a settled small bin grows with depth and the layered soil's exceeds the non-layered one at depth", "[builtin]") {
  const auto dir = std::filesystem::temp_directory_path() / "demfem-builtin-cpt-test";
  std::filesystem::remove_all(dir);  // a soil file left by another version would not be this packing
  std::filesystem::create_directories(dir);
  ::setenv("DEMFEM_SOIL_DIR", dir.c_str(), 1);
  const study::Study layered_study = coneStudy(true), unlayered_study = coneStudy(false);
  campaign::SoilBinModel(campaign::SoilForce::Draught, unlayered_study).prepare({unlayered_study, layered_study}, {});
  const auto layered = penetrate(layered_study);
  const auto unlayered = penetrate(unlayered_study);
  INFO("layered CPR at the deepest grid depth " << layered.mean_Pa.back() << " Pa, non-layered " << unlayered.mean_Pa.back() << " Pa");
  REQUIRE(layered.depth_m.back() >= 0.03);
  REQUIRE(unlayered.depth_m.back() >= 0.03);
  for (const auto* s : {&layered, &unlayered}) CHECK(meanBetween(*s, 0.025, 0.035) > 2 * meanBetween(*s, 0.005, 0.015));
  CHECK(meanBetween(layered, 0.025, 0.035) > 1.2 * meanBetween(unlayered, 0.025, 0.035));
}
