// Inputs no measurement or model could produce are refused with the file and the key, never run
// or answered (docs/reliability.md, "Inputs checked against physics").
#include "process.hpp"

#include "../campaign/weight_drop_fixture.hpp"

#include <catch2/catch.hpp>

using namespace demfem::testing;

namespace {

// Copies the shipped measured example with one sidecar key of every recording replaced.
fs::path measuredWith(const fs::path& dir, const std::string& key, const nlohmann::json& value) {
  fs::create_directories(dir);
  for (const auto& entry : fs::directory_iterator(sourceDir() / "examples" / "data" / "measured")) {
    if (entry.path().extension() != ".json") {
      fs::copy_file(entry.path(), dir / entry.path().filename());
      continue;
    }
    nlohmann::json sidecar = nlohmann::json::parse(readText(entry.path()));
    if (sidecar.contains(key)) sidecar[key] = value;
    std::ofstream(dir / entry.path().filename()) << sidecar.dump(2) << "\n";
  }
  return dir;
}

}  // namespace

TEST_CASE("a DEM step fraction that gives more DEM steps than the limit is refused by validate, naming the key", "[apps]") {
  const fs::path dir = freshDir("implausible-dt");
  nlohmann::json study = shippedStudyJson("quick.json");
  study["dem"]["dt_fraction"] = 1e-12;
  const fs::path file = writeStudy(study, dir / "tiny_step.json");
  Process p({app("demfem"), "validate", file.string(), "--json", (dir / "validate.json").string()}, dir / "validate");
  const int status = p.wait(std::chrono::seconds(60));
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 2);
  const auto doc = nlohmann::json::parse(readText(dir / "validate.json"));
  REQUIRE(doc["studies"][0]["valid"] == false);
  CHECK(doc["studies"][0]["issues"][0]["path"] == "/dem/dt_fraction");
  CHECK(doc["studies"][0]["issues"][0]["message"].get<std::string>().find("more than the limit") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("a depth given in metres or a weight of 1e300 kg is refused by evaluate, naming the file and the key", "[apps]") {
  const fs::path dir = freshDir("implausible-sidecar");
  int variant = 0;
  for (const auto& [key, value] : {std::pair<std::string, double>{"depth_mm", 0.018}, {"mass_kg", 1e300}, {"mass_kg", 0.0}}) {
    const fs::path recs = measuredWith(dir / ("recs" + std::to_string(++variant)), key, value);
    Process p({app("demfem"), "evaluate", recs.string(), "--out", (dir / "out").string(), "--no-plots"}, dir / "evaluate");
    const int status = p.wait(std::chrono::seconds(60));
    INFO(key << " = " << value << ": " << p.err());
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 2);
    CHECK(p.err().find(".json") != std::string::npos);
    CHECK(p.err().find("/" + key) != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "out" / "report.md"));
  }
  fs::remove_all(dir);
}

TEST_CASE("diagnose refuses weight recordings whose mass is given in grams, naming the files, instead of a verdict", "[apps]") {
  const fs::path dir = freshDir("implausible-grams");
  fs::create_directories(dir / "recs");
  demfem::campaign::test::writeRecordings(dir / "recs", {0.05, 0.1}, 1, {});
  for (const auto& entry : fs::directory_iterator(dir / "recs")) {
    if (entry.path().extension() != ".json") continue;
    nlohmann::json sidecar = nlohmann::json::parse(readText(entry.path()));
    sidecar["mass_kg"] = sidecar["mass_kg"].get<double>() * 1000;  // grams written as kilograms
    std::ofstream(entry.path()) << sidecar.dump(2) << "\n";
  }
  Process p({app("demfem"), "diagnose", demfem::campaign::test::fixtureStudyPath().string(), (dir / "recs").string(), "--out",
             (dir / "out").string(), "--no-plots", "--quiet"},
            dir / "diagnose");
  const int status = p.wait(std::chrono::seconds(240));
  INFO(p.err());
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 2);
  CHECK(p.err().find("w0.05_r1.json") != std::string::npos);
  CHECK(p.err().find("times the model's") != std::string::npos);
  CHECK_FALSE(fs::exists(dir / "out" / "report.md"));
  fs::remove_all(dir);
}
