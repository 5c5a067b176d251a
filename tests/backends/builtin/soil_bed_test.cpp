// The built-in deposition's bed (docs/builtin-dem.md, "Soil deposition and reuse"): the gravity
// pour and the density protocol of soil.deposition.bulk_density_kg_m3 on a small two-layer bin, and
// the quick study's bed at rest (docs/builtin-dem.md, "A bed at rest").
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/study/study.hpp"
#include "support/study_in_code.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

using namespace demfem;

namespace {

// A 120 x 120 mm bin with 40 mm of soil in two layers, quick.json-like laws.
study::Study smallBed() {
  study::Study s = support::twoLayerTestBin("soil-bed", study::StudyKind::Coupled);
  s.kind = study::StudyKind::DemOnly;
  support::useBuiltinStep(s, 0.001);
  return s;
}

adapter::SettledSoil deposit(const study::Study& s) {
  builtin::DepositReport report;
  return builtin::depositSoil(s, 1, report, {});
}

std::string refusal(const study::Study& s) {
  try {
    deposit(s);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("a stated bulk density is reached within 1 % and recorded, and one the protocol cannot reach is refused",
          "[builtin][physics]") {
  const study::Study plain_study = smallBed();
  const adapter::SettledSoil plain = deposit(plain_study);
  const double plain_kg_m3 = plain.settling.bulk_density_kg_m3;
  INFO("plain pour: " << plain_kg_m3 << " kg/m3, " << plain.particles.size() << " particles");
  CHECK(plain_kg_m3 == Approx(adapter::bulkDensity(plain.particles, plain_study.soil)).epsilon(1e-12));
  CHECK(plain.settling.target_bulk_density_kg_m3 == 0);
  CHECK(plain.settling.pour_friction_scale == 1);
  CHECK(adapter::unsettledReason(plain.settling).empty());
  // A poured bed of near-equal frictional spheres (friction 0.3, rolling friction 0.1): below random
  // close packing, and near random loose packing (about 0.55 in bulk), lowered by the looser layers
  // along the walls of a bin only 12 diameters wide (measured 0.516, 565 particles, 2026-12-08).
  CHECK(plain.settling.packing_fraction > 0.50);
  CHECK(plain.settling.packing_fraction < 0.64);

  SECTION("3 % denser than the plain pour: within 1 %, by a pour with reduced friction, settled") {
    study::Study dense = plain_study;
    dense.soil.bulk_density_kg_m3 = 1.03 * plain_kg_m3;
    const adapter::SettledSoil soil = deposit(dense);
    CHECK(soil.settling.bulk_density_kg_m3 == Approx(*dense.soil.bulk_density_kg_m3).epsilon(0.01));
    CHECK(soil.settling.target_bulk_density_kg_m3 == *dense.soil.bulk_density_kg_m3);
    CHECK(soil.settling.pour_friction_scale < 1);
    CHECK(soil.settling.pour_friction_scale >= 0);
    CHECK(adapter::unsettledReason(soil.settling).empty());
    CHECK(soil.soil_hash != plain.soil_hash);
  }
  SECTION("5 % looser than the plain pour: refused, naming the key and the plain pour's density") {
    study::Study loose = plain_study;
    loose.soil.bulk_density_kg_m3 = 0.95 * plain_kg_m3;
    const std::string message = refusal(loose);
    INFO(message);
    CHECK(message.find("bulk_density_kg_m3") != std::string::npos);
    CHECK(message.find("looser than the plain gravity pour") != std::string::npos);
  }
  SECTION("a packing fraction of 0.70, above random close packing: refused as denser than the frictionless pour") {
    study::Study impossible = plain_study;
    impossible.soil.bulk_density_kg_m3 = 0.70 * 2600;
    const std::string message = refusal(impossible);
    INFO(message);
    CHECK(message.find("denser than the frictionless pour") != std::string::npos);
  }
}

// A bed at rest (docs/builtin-dem.md, "A bed at rest"): the rest test on the quick study (the
// paper studies' laws: edem-hysteretic normal, edem-linear cohesion, epsd rolling; 1619 particles, seed 1, one thread): its bed, loaded as
// `demfem run` loads it, left alone for 2 s at the run's step. Measured 2026-12-08: rms speed
// 0.0098 mm/s, largest displacement 0.089 mm; on the constant-torque rolling law (edem-standard,
// EDEM's standard rolling friction) the study's bed creeps: 0.36 mm/s, 4.8 mm, 34 particles beyond
// 1 mm, so the bounds below separate a bed at rest from one that is not.
TEST_CASE("the quick study's bed stays at rest for 2 s: rms speed below 0.3 mm/s, no particle moved by 1 mm",
          "[builtin][physics]") {
  study::Study s = study::loadStudy(DEMFEM_SOURCE_DIR "/studies/quick.json");
  s.dem.threads = 1;
  const adapter::SettledSoil soil = deposit(s);
  CHECK(soil.settling.stages == 3);
  CHECK(soil.settling.stages_capped == 0);  // the reload phase ended at rest
  CHECK(adapter::unsettledReason(soil.settling).empty());
  const builtin::RestFigures rest = builtin::measureRest(s, soil, 2.0, 1, {});
  INFO("rms speed " << rest.rms_speed_m_s * 1e3 << " mm/s, largest displacement " << rest.largest_displacement_m * 1e3 << " mm");
  CHECK(rest.rms_speed_m_s < 0.3e-3);
  CHECK(rest.largest_displacement_m < 1e-3);
  CHECK(rest.moved_over_1mm == 0);
  CHECK(rest.end.size() == soil.particles.size());
}
