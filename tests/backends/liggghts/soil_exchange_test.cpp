// One settled soil for both backends: a soil the built-in DEM deposited is what LIGGGHTS starts
// from, and a soil LIGGGHTS deposited is what the built-in DEM starts from, particle for particle
// and bit for bit (positions, radii, layers).
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/backends/liggghts/input_deck.hpp"
#include "small_study.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <random>

using namespace demfem;
namespace fs = std::filesystem;

namespace {

struct SoilDirectory {
  fs::path dir = fs::temp_directory_path() / ("demfem-soil-exchange-" + std::to_string(std::random_device{}()));
  SoilDirectory() {
    fs::create_directories(dir);
    ::setenv("DEMFEM_SOIL_DIR", dir.c_str(), 1);  // the built-in backend's soil directory
  }
  ~SoilDirectory() {
    std::error_code ignored;
    fs::remove_all(dir, ignored);
  }
};

// The particles LIGGGHTS keeps of `soil`: all but those centred in the block cleared around the
// tool's start position (input_deck.cpp: tool width / length / thickness plus r_max on every side).
std::vector<std::array<double, 4>> expectedAfterClearance(const study::Study& study, const adapter::SettledSoil& soil) {
  const auto origin = liggghts::toolStartOrigin(study, 0);
  const auto& g = study.tools[0].geometry;
  const double r = study.soil.diameter_max_m / 2;
  const std::array<double, 3> lo{origin[0] - g.width_m / 2 - r, origin[1] - r, origin[2] - g.thickness_m / 2 - r};
  const std::array<double, 3> hi{origin[0] + g.width_m / 2 + r, origin[1] + g.length_m + r, origin[2] + g.thickness_m / 2 + r};
  std::vector<std::array<double, 4>> kept;
  for (const auto& p : soil.particles) {
    bool inside = true;
    for (int c = 0; c < 3; ++c) inside = inside && p.x_m[c] >= lo[c] && p.x_m[c] <= hi[c];
    if (!inside) kept.push_back({p.x_m[0], p.x_m[1], p.x_m[2], p.radius_m});
  }
  return kept;
}

}  // namespace

TEST_CASE("LIGGGHTS starts from the built-in backend's settled soil, bit for bit", "[liggghts][soil]") {
  const SoilDirectory soil_dir;
  auto study = liggghts::testing::smallStudy();
  study.soil.deposition_backend = study::DepositionBackend::Builtin;
  builtin::DepositReport report;
  const auto file = adapter::settledSoilFile(study, soil_dir.dir);
  adapter::writeSettledSoil(file, builtin::depositSoil(study, 1, report, {}));
  const auto soil = adapter::readSettledSoil(file, study);
  REQUIRE(soil.particles.size() > 100);

  liggghts::BackendOptions options;
  options.soil_directory = soil_dir.dir;
  auto backend = liggghts::makeBackend(study, options);
  CHECK_FALSE(liggghts::soilOrigin(*backend).deposited);
  CHECK(liggghts::soilOrigin(*backend).file == file);
  const auto expected = expectedAfterClearance(study, soil);
  CHECK(expected.size() + 20 > soil.particles.size());  // the clearance takes a few at most
  CHECK(liggghts::particles(*backend) == expected);     // same order, every bit
  const auto record = nlohmann::json::parse(backend->info().soil_json);
  CHECK(record.at("deposition_backend") == "builtin");
  CHECK(record.at("particles") == soil.particles.size());
  CHECK(record.at("file_checksum") == adapter::settledSoilChecksum(file));
}

TEST_CASE("the built-in backend starts from LIGGGHTS' settled soil, bit for bit", "[liggghts][soil]") {
  const SoilDirectory soil_dir;
  const auto study = liggghts::testing::smallStudy();  // deposition backend: liggghts
  liggghts::BackendOptions options;
  options.soil_directory = soil_dir.dir;
  REQUIRE(liggghts::soilOrigin(*liggghts::makeBackend(study, options)).deposited);
  const auto file = adapter::settledSoilFile(study, soil_dir.dir);
  const auto soil = adapter::readSettledSoil(file, study);
  CHECK(soil.backend == study::DepositionBackend::Liggghts);
  CHECK(soil.settling.stages == 1);
  CHECK(soil.settling.surface_height_m == adapter::soilSurfaceHeight(soil.particles, study.soil.diameter_max_m));

  builtin::DemSimulation sim(study.soil, builtin::binDomain(study.soil), 1);
  builtin::addSettledParticles(sim, study.soil, soil);
  REQUIRE(sim.particleCount() == soil.particles.size());
  // The built-in backend orders particles spatially: compare as sorted lists.
  std::vector<std::array<double, 5>> in_file, in_builtin;
  for (const auto& p : soil.particles) in_file.push_back({p.x_m[0], p.x_m[1], p.x_m[2], p.radius_m, double(p.layer)});
  for (std::size_t i = 0; i < sim.particleCount(); ++i) {
    const auto p = sim.particle(i);
    in_builtin.push_back({p.x[0], p.x[1], p.x[2], p.radius, double(p.layer)});
  }
  std::sort(in_file.begin(), in_file.end());
  std::sort(in_builtin.begin(), in_builtin.end());
  CHECK(in_builtin == in_file);

  // And the built-in backend finds and reads that file (it does not deposit one of its own).
  auto builtin_backend = builtin::makeBackend(study);
  const auto record = nlohmann::json::parse(builtin_backend->info().soil_json);
  CHECK(record.at("deposition_backend") == "liggghts");
  CHECK(record.at("file_checksum") == adapter::settledSoilChecksum(file));
}

TEST_CASE("a backend without the soil file of another backend's deposition says which command makes it", "[liggghts][soil]") {
  const SoilDirectory soil_dir;
  auto study = liggghts::testing::smallStudy();
  study.soil.deposition_backend = study::DepositionBackend::Builtin;
  liggghts::BackendOptions options;
  options.soil_directory = soil_dir.dir;
  try {
    liggghts::makeBackend(study, options);
    FAIL("LIGGGHTS built a simulation without the built-in deposition's soil");
  } catch (const adapter::CouplingError& e) {
    CHECK(e.code() == adapter::ErrorCode::BadRequest);
    CHECK_THAT(e.what(), Catch::Contains(adapter::settledSoilFile(study, soil_dir.dir).string()) &&
                             Catch::Contains("demfem deposit"));
  }
}
