// The modal integration (fem/modal.hpp) in the coupled cycle against a real DEM: the built-in backend
// in-process on a small deposited bin, the same run with fem.integration modal and full.
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/study/study.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

using namespace demfem;
namespace fs = std::filesystem;

namespace {

// studies/quick.json made small: a 140 x 80 mm bin filled 40 mm deep (about 500 particles), a
// 120 x 20 mm tool inserted at 300 mm/s and dragged 10 mm at 100 mm/s (95 + 100 FEM steps of 1 ms).
study::Study smallCoupledStudy(const std::string& integration) {
  std::ifstream in(fs::path(DEMFEM_SOURCE_DIR) / "studies" / "quick.json");
  std::stringstream text;
  text << in.rdbuf();
  auto doc = nlohmann::json::parse(text.str());
  doc["soil"]["bin"]["length_mm"] = 140;
  doc["soil"]["bin"]["width_mm"] = 80;
  doc["soil"]["fill_height_mm"] = 40;
  doc["soil"]["layers"][3]["bottom_depth_mm"] = 40;
  auto& tool = doc["tools"][0];
  tool["geometry"]["length_mm"] = 120;
  tool["geometry"]["width_mm"] = 20;
  tool["motion"]["insertion_velocity_mm_s"] = 300;
  tool["motion"]["velocity_mm_s"] = 100;
  tool["motion"]["stroke_mm"] = 10;
  tool["motion"]["start_z_mm"] = 40;
  tool["motion"]["center_x_mm"] = 45;
  doc["fem"]["integration"] = integration;
  const fs::path soil = fs::temp_directory_path() / "demfem-modal-coupled-test-soil";
  fs::create_directories(soil);
  ::setenv("DEMFEM_SOIL_DIR", soil.c_str(), 1);
  return study::parseStudy(doc.dump(), "quick.json (small bin, " + integration + " integration)");
}

struct Columns {
  std::vector<double> force, deformation;
};

Columns coupledRun(const std::string& integration, const fs::path& out) {
  const study::Study study = smallCoupledStudy(integration);
  fem::CoupledRunOptions options;
  options.output_dir = out;
  fem::CoupledDriver driver(study, options);
  const auto dem = builtin::makeBackend(study);
  REQUIRE(driver.run(*dem).complete);
  std::ifstream in(out / "sensors.csv");
  std::string line;
  std::getline(in, line);
  Columns c;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) v.push_back(std::stod(cell));
    c.force.push_back(v.at(2));
    c.deformation.push_back(v.at(3));
  }
  return c;
}

// Largest |a - b| relative to the largest |b|.
double deviation(const std::vector<double>& a, const std::vector<double>& b) {
  REQUIRE(a.size() == b.size());
  double range = 0, worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    range = std::max(range, std::abs(b[i]));
    worst = std::max(worst, std::abs(a[i] - b[i]));
  }
  return worst / range;
}

}  // namespace

TEST_CASE("against the built-in DEM the modal integration reads the full integration's load cell and deformation within 0.1 %",
          "[fem][physics]") {
  const fs::path dir = fs::temp_directory_path() / ("demfem-modal-coupled-" + std::to_string(std::random_device{}()));
  const Columns full = coupledRun("full", dir / "full");
  const Columns modal = coupledRun("modal", dir / "modal");
  REQUIRE(full.force.size() == 100);
  REQUIRE(*std::max_element(full.force.begin(), full.force.end()) > 0.1);  // the soil loads the tool
  CHECK(deviation(modal.force, full.force) < 1e-3);
  CHECK(deviation(modal.deformation, full.deformation) < 1e-3);
  fs::remove_all(dir);
}
