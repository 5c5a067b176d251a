// The key table: docs/study-file.md's generated key reference is what the table gives; validate()
// applies the loader's gate to studies built in code; every contact law has one trait.
#include "demfem/study/contact_laws.hpp"
#include "demfem/study/study.hpp"

#include "source_files.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

using demfem::study::Study;
using demfem::study::StudyError;

namespace {

using demfem::study::testing::kSource;
using demfem::study::testing::readText;
const std::filesystem::path kBinary = DEMFEM_BINARY_DIR;
constexpr const char* kBegin = "<!-- key reference: generated from the key table, do not edit -->\n";
constexpr const char* kEnd = "<!-- end of key reference -->";

Study quick() { return demfem::study::loadStudy(kSource / "studies/quick.json"); }

}  // namespace

TEST_CASE("docs/study-file.md's key reference is the table the loader reads", "[study]") {
  const std::string doc = readText(kSource / "docs/study-file.md");
  const std::size_t begin = doc.find(kBegin);
  const std::size_t end = doc.find(kEnd);
  REQUIRE(begin != std::string::npos);
  REQUIRE(end != std::string::npos);
  const std::string documented = doc.substr(begin + std::string(kBegin).size(), end - begin - std::string(kBegin).size());
  const std::string generated = demfem::study::keyReference();
  if (documented != generated) {
    // For the fix: the table as it should stand between the markers.
    const std::filesystem::path expected = kBinary / "study-file-key-reference.md";
    std::ofstream(expected) << generated;
    FAIL("docs/study-file.md's key reference differs from the key table; the table is in " << expected.string());
  }
  // Every key of the effective quick study has its row.
  CHECK(generated.find("| `tools[].motion.depth_mm` | mm | > 0 and <= 1e5 | required |") != std::string::npos);
  CHECK(generated.find("| `dem.seed` | integer | >= 0 and <= 9223372036854775807 | 1 |") != std::string::npos);
}

TEST_CASE("validate judges a study built in code by the loader's rules, naming JSON paths", "[study]") {
  Study s = quick();
  CHECK_NOTHROW(demfem::study::validate(s));
  s.tools[0].fem.youngs_Pa = -4.06e9;             // a range
  s.tools[0].motion.depth_m = 0.2;                // a cross-field rule: deeper than the soil
  s.soil.contact.stiffness_factor = 0.85;         // applies to edem-hysteretic: fine
  try {
    demfem::study::validate(s);
    FAIL("validate accepted a negative modulus");
  } catch (const StudyError& e) {
    REQUIRE(e.issues().size() == 3);
    CHECK(e.issues()[0].path == "/tools/0/fem/E_Pa");
    CHECK(e.issues()[0].message == "must be >= 1000 and <= 1e13, got -4.06e9");
    CHECK(e.issues()[1].path == "/tools/0/motion/depth_mm");
    CHECK(e.issues()[2].path == "/tools/0/motion/depth_mm");  // also beyond the tool's free length
    CHECK(e.file() == (kSource / "studies/quick.json").string());
  }
  Study unnamed = quick();
  unnamed.source.clear();
  unnamed.name = "a/b";
  try {
    demfem::study::validate(unnamed);
    FAIL("validate accepted a name that is not a file name");
  } catch (const StudyError& e) {
    REQUIRE(e.issues().size() == 1);
    CHECK(e.issues()[0].path == "/name");
    CHECK(e.file() == "study \"a/b\"");
  }
}

TEST_CASE("each normal law's trait names the contact keys the study file accepts for it", "[study]") {
  using namespace demfem::study;
  for (NormalModel m : kAllNormalModels) {
    Study s = quick();
    s.soil.contact.normal = m;
    const nlohmann::json contact = toJson(s)["soil"]["contact"];
    const unsigned uses = normalLawParameters(m);
    CHECK(contact.contains("stiffness_factor") == bool(uses & kStiffnessFactor));
    CHECK(contact.contains("characteristic_velocity_m_s") == bool(uses & kCharacteristicVelocity));
    CHECK(contact.contains("coefficient_plasticity_depth") == bool(uses & kCoefficientPlasticityDepth));
    CHECK(contact["normal"] == withNormalLaw(m, [](auto law) { return std::string(decltype(law)::name); }));
  }
  CHECK(normalLawParameters(NormalModel::Hooke) == kCharacteristicVelocity);
  CHECK_FALSE(rollingUsesFriction(RollingModel::None));
  CHECK(cohesionUsesEnergyDensity(CohesionModel::Sjkr2));
}
