// The FEM client (fem/coupled_driver.hpp) coupled in-process to the builtin backend on a small
// deposited bin: the tool's motion has one owner (the plan, study/tool_motion.hpp) and the FEM and
// DEM output files share one clock.
#include "demfem/adapter/output_files.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/study/study.hpp"
#include "demfem/study/tool_motion.hpp"
#include "support/motion_recorder.hpp"
#include "support/small_study.hpp"
#include "support/temp_dir.hpp"

#include "demfem/vtkio/vtk_files.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

using namespace demfem;
namespace fs = std::filesystem;

namespace {

// studies/quick.json made small (support/small_study.hpp): a 140 x 80 mm bin filled 40 mm deep
// (about 500 particles), a 120 x 20 mm tool off the bin's centre line (x = 45 mm), inserted at
// 300 mm/s and dragged 10 mm at 100 mm/s: 95 + 100 FEM steps of 1 ms. The settled soil is shared by
// the runs of this file.
study::Study smallCoupledStudy(const fs::path& out) {
  auto doc = support::shippedStudyJson("quick.json");
  support::useSmallBin(doc);
  support::useSmallTool(doc);
  support::useShortStroke(doc, 10);
  doc["tools"][0]["motion"]["center_x_mm"] = 45;
  doc["output"]["vtk_every"] = 10;
  doc["output"]["directory"] = out.string();
  const fs::path soil = fs::temp_directory_path() / "demfem-builtin-coupled-test-soil";
  fs::create_directories(soil);
  ::setenv("DEMFEM_SOIL_DIR", soil.c_str(), 1);
  return study::parseStudy(doc.dump(), "quick.json (small bin, builtin coupled test)");
}

// file -> timestep of a .pvd collection, read by VTK's XML parser.
std::map<std::string, double> pvdEntries(const fs::path& file) {
  std::map<std::string, double> entries;
  for (const auto& e : vtkio::readCollection(file)) entries[e.file.filename().string()] = e.time_s;
  return entries;
}

}  // namespace

TEST_CASE("a coupled run on the builtin DEM moves the tool once: down from the plan's start to the depth, never up",
          "[builtin][fem][physics]") {
  const fs::path dir = support::freshDir("builtin-coupled");
  const study::Study study = smallCoupledStudy(dir / "out");
  const study::ToolMotionPlan plan = study::planToolMotion(study, study.tools[0]);
  REQUIRE(plan.insertion_steps == 95);  // (18 + 10.5) mm at 300 mm/s in whole 1 ms steps
  REQUIRE(plan.drag_steps == 100);

  auto backend = builtin::makeBackend(study);
  support::MotionRecorder dem(*backend, study.tools[0].name);
  // Built at rest at the plan's start pose, on a clock at 0 (coupling_api.hpp).
  CHECK(dem.initial_time_s == 0);
  CHECK(dem.initial.origin_m[0] == Approx(0.045).margin(1e-15));
  CHECK(dem.initial.origin_m[1] == Approx(0.040 + 0.0105).margin(1e-15));
  CHECK(dem.initial.origin_m[2] == Approx(0.040 - 0.002).margin(1e-15));
  CHECK(dem.initial.velocity_m_s == std::array<double, 3>{0, 0, 0});

  fem::CoupledRunOptions options;
  options.output_dir = dir / "out";
  const fem::CoupledRunSummary summary = fem::CoupledDriver(study, options).run(dem);
  CHECK(summary.complete);
  support::checkMovesDownOnceToDepth(dem.heights_m, study, plan);

  // One clock: at every instant both wrote, the FEM's tool nodes are the DEM's (the DEM files are
  // written by the backend itself into output.directory/vtk), and both collections give the DEM time.
  const fs::path vtk = dir / "out" / "vtk";
  const std::string& tool = study.tools[0].name;
  const auto fem_series = pvdEntries(vtk / ("fem-" + tool + ".pvd")), dem_series = pvdEntries(vtk / ("dem-" + tool + ".pvd"));
  CHECK(fem_series.size() == static_cast<std::size_t>((plan.totalSteps() - 1) / 10 + 1));  // steps 0, 10, ..., 190
  CHECK(dem_series.size() == fem_series.size());
  CHECK(pvdEntries(vtk / "particles.pvd").size() == dem_series.size());
  double largest_gap = 0;
  for (const auto& [fem_file, fem_time] : fem_series) {
    // fem-TOOL_NNNNNN.vtu -> dem-TOOL_NNNNNN.vtp
    const std::string dem_file = "dem-" + fem_file.substr(4, fem_file.size() - 8) + ".vtp";
    INFO(fem_file << " at t = " << fem_time << " s");
    REQUIRE(dem_series.count(dem_file) == 1);
    CHECK(dem_series.at(dem_file) == fem_time);
    const int step = std::stoi(fem_file.substr(9, 6));
    CHECK(fem_time == Approx(step * study.fem.dt_s).margin(1e-12));
    const auto fem_data = vtkio::read(vtk / fem_file), dem_data = vtkio::read(vtk / dem_file);
    CHECK(fem_data.time_s == fem_time);  // each file's own time is the collection's
    CHECK(dem_data.time_s == fem_time);
    CHECK(fem_data.triangles == dem_data.triangles);
    CHECK(fem_data.array("force_N").values.size() == dem_data.array("force_N").values.size());
    const auto &a = fem_data.points, &b = dem_data.points;
    REQUIRE(a.size() == b.size());
    for (std::size_t v = 0; v < a.size(); ++v) largest_gap = std::max(largest_gap, std::abs(a[v] - b[v]));
  }
  CHECK(largest_gap < 1e-9);
  fs::remove_all(dir);
}

TEST_CASE("a coupled run on the builtin DEM refuses an output directory another run holds and writes nothing there",
          "[builtin][fem]") {
  const fs::path dir = support::freshDir("builtin-coupled-locked");
  const study::Study study = smallCoupledStudy(dir / "out");
  const adapter::DirectoryLock other_run(dir / "out");
  auto backend = builtin::makeBackend(study);
  fem::CoupledRunOptions options;
  options.output_dir = dir / "out";
  CHECK_THROWS_WITH(fem::CoupledDriver(study, options).run(*backend), Catch::Contains("is in use by another run"));
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir / "out")) files.push_back(e.path().filename().string());
  CHECK(files == std::vector<std::string>{adapter::DirectoryLock::kFileName});
}

TEST_CASE("a coupled run on the builtin DEM writes the same bytes whether its tool's reduction and modal basis were computed or read from the cache",
          "[builtin][fem]") {
  const fs::path dir = support::freshDir("builtin-coupled-reduction-cache");
  const auto run = [&](const std::string& name, std::optional<fs::path> cache) {
    const study::Study study = smallCoupledStudy(dir / name);
    auto backend = builtin::makeBackend(study);
    fem::CoupledRunOptions options;
    options.output_dir = dir / name;
    options.reduction_cache_dir = std::move(cache);
    REQUIRE(fem::CoupledDriver(study, options).run(*backend).complete);
    return support::readText(dir / name / "sensors.csv") + support::readText(dir / name / "keypoint_displacements.f64");
  };
  const std::string reduced = run("reduced", std::nullopt);
  const std::string written = run("written", dir / "cache");  // reduced, then written to the cache
  const std::string read = run("read", dir / "cache");
  REQUIRE(reduced.size() > 1000);
  CHECK(written == reduced);
  CHECK(read == reduced);
  std::map<std::string, int> files;  // one reduction and one modal basis
  for (const auto& e : fs::directory_iterator(dir / "cache")) ++files[e.path().filename().string().substr(0, e.path().filename().string().find('-'))];
  CHECK(files == std::map<std::string, int>{{"modal", 1}, {"reduction", 1}});
  fs::remove_all(dir);
}
