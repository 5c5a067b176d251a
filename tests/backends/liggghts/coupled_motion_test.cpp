// The FEM client (fem/coupled_driver.hpp) coupled in-process to the liggghts backend on a small
// deposited bin: the tool's motion has one owner, the plan (study/tool_motion.hpp).
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/study/study.hpp"
#include "demfem/study/tool_motion.hpp"
#include "support/motion_recorder.hpp"
#include "support/small_study.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <filesystem>

using namespace demfem;
namespace fs = std::filesystem;

namespace {

// studies/quick_liggghts.json made small (support/small_study.hpp): a 140 x 80 mm bin filled 40 mm
// deep, a 120 x 20 mm tool off the centre line (x = 30 mm), inserted at 300 mm/s and dragged 10 mm
// at 100 mm/s (95 + 100 FEM steps of 1 ms).
study::Study smallCoupledStudy() {
  auto doc = support::shippedStudyJson("quick_liggghts.json");
  support::useSmallBin(doc);
  support::useSmallTool(doc);
  support::useShortStroke(doc, 10);
  doc["soil"]["deposition"]["backend"] = "liggghts";  // a LIGGGHTS-only test: LIGGGHTS deposits its soil
  doc["tools"][0]["motion"]["center_x_mm"] = 30;
  doc["dem"]["backend"] = "liggghts";
  return study::parseStudy(doc.dump(), "quick_liggghts.json (small bin, coupled motion test)");
}

}  // namespace

TEST_CASE("a coupled run on LIGGGHTS moves the tool once: down from the plan's start to the depth, never up",
          "[liggghts][fem][physics]") {
  const fs::path dir = support::freshDir("liggghts-motion");
  liggghts::BackendOptions backend_options;
  backend_options.soil_directory = dir / "soil";
  const study::Study study = smallCoupledStudy();
  const study::ToolMotionPlan plan = study::planToolMotion(study, study.tools[0]);
  auto backend = liggghts::makeBackend(study, backend_options);

  // Built at rest at the plan's start pose (x = center_x), clock at 0 (coupling_api.hpp).
  const auto initial = backend->rigidMotion(study.tools[0].name);
  CHECK(backend->time() == 0);
  for (std::size_t c = 0; c < 3; ++c) {
    CHECK(initial.origin_m[c] == Approx(plan.start_m[c]).margin(1e-15));
    CHECK(initial.velocity_m_s[c] == 0);
  }
  CHECK(plan.start_m[0] == Approx(0.030).margin(1e-15));

  support::MotionRecorder dem(*backend, study.tools[0].name);
  fem::CoupledRunOptions options;
  options.output_dir = dir / "out";
  const auto summary = fem::CoupledDriver(study, options).run(dem);
  CHECK(summary.complete);
  support::checkMovesDownOnceToDepth(dem.heights_m, study, plan);
  // LIGGGHTS moved its mesh by that motion and no other: its nodes minus the rigid motion are the
  // positions the FEM client set (1e-9 m: LIGGGHTS integrates the mesh velocity step by step).
  CHECK(dem.largest_mesh_offset_m < 1e-9);
  fs::remove_all(dir);
}
