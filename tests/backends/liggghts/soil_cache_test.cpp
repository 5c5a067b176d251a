// The settled-soil cache: the first construction deposits and saves the soil, the next one reads it
// and the two simulations are the same.
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/adapter/tool_drive.hpp"
#include "small_study.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <random>

using namespace demfem;
namespace fs = std::filesystem;

namespace {

struct Snapshot {
  std::vector<std::array<double, 4>> particles;  // at construction (after the tools' space was cleared)
  adapter::NodeArray drag_forces;                // interval mean of a short drag
};

Snapshot constructAndDrag(const study::Study& study, const liggghts::BackendOptions& options, bool expect_deposit) {
  auto backend = liggghts::makeBackend(study, options);
  const auto origin = liggghts::soilOrigin(*backend);
  CHECK(origin.deposited == expect_deposit);
  CHECK(origin.file.parent_path() == options.soil_directory);
  CHECK(fs::exists(origin.file));
  Snapshot s{liggghts::particles(*backend), {}};
  adapter::insertAndStartDrag(*backend, study, study.tools[0]);
  backend->simulate(0.02);
  s.drag_forces = backend->nodeForces("tool", adapter::ForceMode::IntervalMean);
  return s;
}

}  // namespace

TEST_CASE("a second construction reads the saved soil instead of depositing and simulates the same", "[liggghts]") {
  const auto study = liggghts::testing::smallStudy();
  liggghts::BackendOptions options;
  options.soil_directory = fs::temp_directory_path() / ("demfem-liggghts-soil-" + std::to_string(std::random_device{}()));
  const Snapshot deposited = constructAndDrag(study, options, true);
  const Snapshot loaded = constructAndDrag(study, options, false);
  REQUIRE(deposited.particles.size() > 100);
  // The deposition overfills and trims to the fill height, as the built-in backend does: no centre
  // above it, and the top particles reach it (within one largest diameter).
  double highest_centre = 0;
  for (const auto& p : deposited.particles) highest_centre = std::max(highest_centre, p[1]);
  CHECK(highest_centre <= study.soil.fill_height_m);
  CHECK(highest_centre > study.soil.fill_height_m - study.soil.diameter_max_m);
  // Both simulations start from the file's particles at rest: identical to the last bit, and so is
  // the drag that follows (one rank, same commands).
  CHECK(loaded.particles == deposited.particles);
  CHECK(loaded.drag_forces == deposited.drag_forces);
  double draught = 0;
  for (std::size_t k = 2; k < loaded.drag_forces.size(); k += 3) draught -= loaded.drag_forces[k];
  CHECK(draught > 0);  // the drag touched the soil: the comparison of forces is not between zeros

  SECTION("a given settled soil replaces the cached one") {
    liggghts::BackendOptions given;
    given.soil_directory = options.soil_directory;
    for (const auto& p : deposited.particles) given.settled_soil.push_back({{p[0], p[1], p[2]}, p[3], "soil"});
    given.settled_soil.pop_back();  // one particle fewer: not the cached soil
    auto backend = liggghts::makeBackend(study, given);
    CHECK(liggghts::soilOrigin(*backend).file.empty());
    auto expected = deposited.particles;
    expected.pop_back();
    CHECK(liggghts::particles(*backend) == expected);
  }

  SECTION("a damaged soil file is reported, not replaced") {
    const fs::path file = liggghts::soilOrigin(*liggghts::makeBackend(study, options)).file;
    fs::resize_file(file, fs::file_size(file) / 2);
    try {
      liggghts::makeBackend(study, options);
      FAIL("a truncated soil file was accepted");
    } catch (const adapter::CouplingError& e) {
      CHECK(e.code() == adapter::ErrorCode::BadRequest);
      CHECK_THAT(e.what(), Catch::Contains(file.string()) && Catch::Contains("truncated"));
    }
  }
  fs::remove_all(options.soil_directory);
}
