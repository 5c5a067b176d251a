// The keypoint-reduction cache (fem/reduction_cache.hpp): what it reads back is reduce()'s result
// bit for bit, its key follows everything reduce() reads, and a damaged file is refused by name.
#include "fem_test_tools.hpp"

#include "demfem/fem/reduction_cache.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <fstream>
#include <stdexcept>

using namespace demfem;
using namespace demfem::fem;

namespace {

void checkIdentical(const ReducedModel& a, const ReducedModel& b) {
  CHECK(a.K == b.K);  // exact: the cache must not change a run's numbers
  CHECK(a.M == b.M);
  CHECK(a.keypoints == b.keypoints);
  CHECK(a.length_m == b.length_m);
  CHECK(a.constraints.fixed_dofs == b.constraints.fixed_dofs);
  CHECK(a.constraints.load_cell_dofs == b.constraints.load_cell_dofs);
  CHECK(a.constraints.springs == b.constraints.springs);
}

}  // namespace

TEST_CASE("a cached keypoint reduction is reduce()'s bit for bit, written on the first call and read on the next", "[fem]") {
  const support::TempDir dir("reduction-cache");
  study::Tool tool = testing::smallStrip();
  tool.constraints.clamp_rotational_stiffness_Nm_per_rad = 50.0;  // springs travel through the file too
  const FullModel full = buildPlateModel(tool);
  const ReducedModel direct = reduce(full);
  REQUIRE(!direct.constraints.springs.empty());

  int progress_calls = 0;
  const ReducedModel first = reduceCached(full, dir.path() / "cache", [&](double) { ++progress_calls; });
  CHECK(progress_calls > 1);  // reduced: the column blocks reported
  CHECK(std::filesystem::exists(reductionFile(full, dir.path() / "cache")));
  checkIdentical(first, direct);

  std::vector<double> read_progress;
  const ReducedModel second = reduceCached(full, dir.path() / "cache", [&](double f) { read_progress.push_back(f); });
  CHECK(read_progress == std::vector<double>{1.0});  // read, not reduced
  checkIdentical(second, direct);
}

TEST_CASE("the reduction's key follows everything reduce() reads, not how the model was built", "[fem]") {
  const study::Tool tool = testing::smallStrip();
  const FullModel full = buildPlateModel(tool);
  CHECK(fullModelHash(full).size() == 16);
  CHECK(fullModelHash(buildPlateModel(tool)) == fullModelHash(full));  // built again: the same key

  study::Tool stiffer = tool;
  stiffer.fem.youngs_Pa *= 1.0 + 1e-12;  // the last digits of K
  CHECK(fullModelHash(buildPlateModel(stiffer)) != fullModelHash(full));
  study::Tool heavier = tool;
  heavier.fem.density_kg_m3 += 1;
  CHECK(fullModelHash(buildPlateModel(heavier)) != fullModelHash(full));
  study::Tool load_cell_lower = tool;
  load_cell_lower.constraints.load_cell_from_top_m += 0.005;  // another keypoint row
  CHECK(fullModelHash(buildPlateModel(load_cell_lower)) != fullModelHash(full));

  FullModel moved = full;
  moved.keypoints(0, 0) += 1e-9;
  CHECK(fullModelHash(moved) != fullModelHash(full));
  FullModel longer = full;
  longer.length_m += 1e-9;
  CHECK(fullModelHash(longer) != fullModelHash(full));
}

TEST_CASE("a damaged or misnamed reduction file is refused, naming the file, the failed check and the remedy", "[fem]") {
  const support::TempDir dir("reduction-cache-damaged");
  const FullModel full = buildPlateModel(testing::smallStrip());
  const auto cache = dir.path() / "cache";
  reduceCached(full, cache);
  const auto file = reductionFile(full, cache);

  SECTION("one byte changed in the matrices") {
    std::fstream io(file, std::ios::in | std::ios::out | std::ios::binary);
    io.seekp(-100, std::ios::end);
    io.put('\x7f');
    io.close();
    CHECK_THROWS_WITH(reduceCached(full, cache), Catch::Contains(file.string()) && Catch::Contains("checksum") &&
                                                     Catch::Contains("delete the file"));
  }
  SECTION("cut short") {
    std::filesystem::resize_file(file, std::filesystem::file_size(file) / 2);
    CHECK_THROWS_WITH(reduceCached(full, cache), Catch::Contains(file.string()) && Catch::Contains("delete the file"));
  }
  SECTION("another model's file under this model's name") {
    study::Tool other = testing::smallStrip();
    other.fem.youngs_Pa *= 2;
    const FullModel other_full = buildPlateModel(other);
    reduceCached(other_full, cache);
    std::filesystem::rename(reductionFile(other_full, cache), file);
    CHECK_THROWS_WITH(reduceCached(full, cache), Catch::Contains(file.string()) && Catch::Contains("records the hash " + fullModelHash(other_full)));
  }
}

TEST_CASE("the reduction cache's directory is $DEMFEM_FEM_CACHE_DIR, else fem-cache", "[fem]") {
  const char* previous = std::getenv("DEMFEM_FEM_CACHE_DIR");
  const std::string restore = previous ? previous : "";
  ::setenv("DEMFEM_FEM_CACHE_DIR", "/some/where", 1);
  CHECK(defaultReductionDirectory() == "/some/where");
  ::setenv("DEMFEM_FEM_CACHE_DIR", "", 1);
  CHECK(defaultReductionDirectory() == "fem-cache");
  ::unsetenv("DEMFEM_FEM_CACHE_DIR");
  CHECK(defaultReductionDirectory() == "fem-cache");
  if (previous) ::setenv("DEMFEM_FEM_CACHE_DIR", restore.c_str(), 1);
}

TEST_CASE("a cached modal basis is modalBasis()'s bit for bit, one file per model and step", "[fem]") {
  const support::TempDir dir("modal-basis-cache");
  const FullModel full = buildPlateModel(testing::smallStrip());
  const ReducedModel reduced = reduce(full);
  const double dt_s = 1e-3;
  const ModalBasis direct = modalBasis(reduced, dt_s);
  for (int pass = 0; pass < 2; ++pass) {  // written, then read
    INFO("pass " << pass);
    const ModalBasis cached = modalBasisCached(full, reduced, dt_s, dir.path());
    CHECK((cached.omega2 == direct.omega2).all());
    CHECK(cached.phi == direct.phi);
    CHECK(cached.residual == direct.residual);
    CHECK(cached.highest_mode_Hz == direct.highest_mode_Hz);
  }
  modalBasisCached(full, reduced, dt_s / 2, dir.path());  // another step: another basis
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) files.push_back(e.path());
  REQUIRE(files.size() == 2);
  for (const auto& file : files) CHECK(file.filename().string().rfind("modal-", 0) == 0);

  std::filesystem::resize_file(files[0], std::filesystem::file_size(files[0]) - 8);
  const auto damaged = [&] {
    modalBasisCached(full, reduced, dt_s, dir.path());
    modalBasisCached(full, reduced, dt_s / 2, dir.path());
  };
  CHECK_THROWS_WITH(damaged(), Catch::Contains("modal basis cache " + files[0].string()) && Catch::Contains("delete the file"));
}

TEST_CASE("a modal integrator refuses a basis that does not fit its model", "[fem]") {
  const ReducedModel strip = reduce(buildPlateModel(testing::smallStrip()));
  study::Tool longer = testing::smallStrip();
  support::usePlate(longer, 0.120, 0.010, 0.004);
  const ModalBasis other = modalBasis(reduce(buildPlateModel(longer)), 1e-3);
  CHECK_THROWS_WITH(ModalIntegrator(strip, other, 1e-3, RayleighDamping{0.55e-3, 0}), Catch::Contains("does not fit the model's"));
}
