// `demfem deposit --backend builtin|liggghts`: one settled-soil file per deposition backend, a
// second call reuses it, and --json - writes exactly one JSON document to standard output.
#include "demfem/adapter/settled_soil.hpp"
#include "process.hpp"

#include <catch2/catch.hpp>

using namespace demfem::testing;

namespace {

// quick_liggghts.json on a 120 x 80 mm bin filled to 40 mm (four 10 mm layers): seconds to deposit.
fs::path smallBinStudy(const fs::path& dir) {
  nlohmann::json study = shippedStudyJson("quick_liggghts.json");
  useSmallBin(study, 120);
  auto& motion = study["tools"][0]["motion"];
  motion["start_z_mm"] = 20;
  motion["stroke_mm"] = 20;
  motion["depth_mm"] = 10;
  return writeStudy(study, dir / "small_bin.json");
}

nlohmann::json deposit(const fs::path& study, const fs::path& soil_dir, const std::string& backend, const fs::path& log) {
  Process p({app("demfem"), "deposit", study.string(), "--backend", backend, "--soil-dir", soil_dir.string(), "--json", "-"},
            log);
  const int status = p.wait(240s);
  INFO(p.err());
  REQUIRE(exitedOk(status));
  return nlohmann::json::parse(p.out());  // throws unless stdout is exactly one JSON document
}

}  // namespace

TEST_CASE("demfem deposit --backend makes one soil file per deposition backend and reuses it", "[apps][soil]") {
  const fs::path dir = freshDir("deposit");
  const fs::path study = smallBinStudy(dir);
  const auto liggghts = deposit(study, dir / "soil", "liggghts", dir / "deposit-liggghts");
  CHECK(liggghts.at("reused") == false);
  CHECK(liggghts.at("deposition_backend") == "liggghts");
  CHECK(liggghts.at("particles").get<int>() > 50);
  const fs::path file = liggghts.at("soil_file").get<std::string>();
  const auto soil = demfem::adapter::readSettledSoil(file);
  CHECK(soil.backend == "liggghts");
  CHECK(soil.particles.size() == liggghts.at("particles").get<std::size_t>());
  CHECK(liggghts.at("file_checksum") == demfem::adapter::settledSoilChecksum(file));

  const auto again = deposit(study, dir / "soil", "liggghts", dir / "deposit-again");
  CHECK(again.at("reused") == true);
  CHECK(again.at("file_checksum") == liggghts.at("file_checksum"));

  const auto builtin = deposit(study, dir / "soil", "builtin", dir / "deposit-builtin");
  CHECK(builtin.at("deposition_backend") == "builtin");
  CHECK(builtin.at("soil_file") != liggghts.at("soil_file"));  // another deposition, another soil
  CHECK(builtin.at("stages") == 3);  // the pour (all layers, one rain), the final settling and the reload phase
  CHECK(builtin.at("bulk_density_kg_m3").get<double>() > 0);
  CHECK(builtin.at("target_bulk_density_kg_m3").is_null());  // the plain gravity pour
  fs::remove_all(dir);
}
