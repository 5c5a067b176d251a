// The coupled driver against an in-process analytic backend (no processes, no sockets).
#include "demfem/adapter/forwarding_api.hpp"
#include "demfem/adapter/test_backends.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"
#include "demfem/study/study.hpp"
#include "demfem/study/tool_motion.hpp"
#include "support/small_study.hpp"
#include "test_backend_run.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

using namespace demfem;

namespace {

// Forwards to a test backend and records every rigid motion the driver sets.
class RecordingBackend final : public adapter::ForwardingApi {
 public:
  explicit RecordingBackend(std::unique_ptr<adapter::CouplingApi> backend) : ForwardingApi(*backend), backend_(std::move(backend)) {}
  std::vector<adapter::RigidMotion> motions;

  void setRigidMotion(const std::string& g, const adapter::RigidMotion& m) override {
    motions.push_back(m);
    inner().setRigidMotion(g, m);
  }

 private:
  std::unique_ptr<adapter::CouplingApi> backend_;
};

// studies/quick.json with a small tool (120 x 20 mm) so the reduction is quick.
study::Study smallQuickStudy() {
  auto doc = demfem::support::shippedStudyJson("quick.json");
  demfem::support::useSmallTool(doc);
  return study::parseStudy(doc.dump(), "quick.json (small tool)");
}

}  // namespace

TEST_CASE("coupled driver times insertion and drag from the DEM clock, which need not start at zero", "[fem]") {
  const study::Study study = smallQuickStudy();
  RecordingBackend dem(adapter::makeTestBackend("constant", study.tools, adapter::TestLoad{}));
  const double clock_at_start = 0.25;  // e.g. a settled soil resumed at its own time
  dem.simulate(clock_at_start);
  REQUIRE(dem.time() == Approx(clock_at_start).margin(1e-12));

  fem::CoupledRunOptions options;
  options.output_dir = std::filesystem::temp_directory_path() / "demfem-driver-clock-test";
  std::filesystem::remove_all(options.output_dir);
  std::filesystem::create_directories(options.output_dir);
  const auto& motion = study.tools[0].motion;
  const double dt = study.fem.dt_s;
  const auto insertion_steps =
      static_cast<std::int64_t>(std::ceil((motion.depth_m + study.soil.diameter_max_m) / motion.insertion_velocity_m_s / dt - 1e-9));
  options.max_steps = insertion_steps + 3;
  fem::CoupledDriver(study, options).run(dem);

  REQUIRE(dem.motions.size() == 2);
  const auto& insertion = dem.motions.front();
  const auto& drag = dem.motions.back();
  // Insertion starts now on the DEM's clock; the drag starts where and when the insertion ends.
  CHECK(insertion.t0_s == Approx(clock_at_start).margin(1e-12));
  CHECK(drag.t0_s == Approx(clock_at_start + insertion_steps * dt).margin(1e-12));
  for (int c = 0; c < 3; ++c)
    CHECK(insertion.origin_m[c] + insertion.velocity_m_s[c] * (drag.t0_s - insertion.t0_s) ==
          Approx(drag.origin_m[c]).margin(1e-12));
  // The drag holds the study's depth below the fill surface and moves at the study's velocity in +z.
  CHECK(drag.origin_m[1] == Approx(study.soil.fill_height_m - motion.depth_m).margin(1e-12));
  CHECK(drag.velocity_m_s[2] == Approx(motion.velocity_m_s).margin(1e-12));
  std::filesystem::remove_all(options.output_dir);
}

namespace {

// Runs the driver on the constant test backend (10 N against travel on the tip row) for the
// insertion and `drag_rows` drag steps; returns the sensors.csv load-cell column.
std::vector<double> loadCellColumn(const study::Study& study, const std::filesystem::path& out, int drag_rows) {
  fem::testing::runOnTestBackend(study, "constant", adapter::TestLoad{}, out, drag_rows);
  return fem::testing::readSensorColumns(out / "sensors.csv").force;
}

}  // namespace

TEST_CASE("a DEM-only (rigid) and a coupled run of the same tool read the same load cell for the same static forces", "[fem]") {
  const study::Study coupled = smallQuickStudy();
  auto doc = study::toJson(coupled);
  doc["kind"] = "dem-only";
  doc["tools"][0]["fem"].erase("alpha_s");
  doc["tools"][0]["fem"].erase("beta_per_s");
  doc["tools"][0].erase("sensors");  // ideal gains: a rigid tool has no sensor gains to set
  const study::Study rigid = study::parseStudy(doc.dump(), "quick.json (small tool, dem-only)");
  REQUIRE_FALSE(rigid.tools[0].fem.deformable);

  const auto dir = std::filesystem::temp_directory_path() / "demfem-driver-rigid-test";
  std::filesystem::remove_all(dir);
  const auto deformable_N = loadCellColumn(coupled, dir / "coupled", 5);
  const auto rigid_N = loadCellColumn(rigid, dir / "rigid", 5);
  // The reference: the static FEM solution under the same forces (CalculiX-checked sensors).
  const fem::ReducedModel model = fem::reduce(fem::buildFullModel(coupled.tools[0]));
  const fem::StaticSolution s = fem::solveStatic(model, [&] {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(model.dofCount());
    int tip = 0;
    for (int k = 0; k < model.keypointCount(); ++k) tip += std::abs(model.keypoints(k, 1)) < 1e-12;
    for (int k = 0; k < model.keypointCount(); ++k)
      if (std::abs(model.keypoints(k, 1)) < 1e-12) f(3 * k + 2) = adapter::TestLoad{}.force_N / tip;
    return f;
  }());
  const double expected_N = fem::Sensors(model, coupled.tools[0]).read(s.displacement, s.reaction).load_cell_N;
  REQUIRE(expected_N > 10);  // against travel, and more than the load itself (propped cantilever)
  REQUIRE(rigid_N.size() == 5);
  REQUIRE(deformable_N.size() == 5);
  for (std::size_t i = 0; i < 5; ++i) {
    // The coupled tool starts in static equilibrium and the load never changes: it stays there.
    CHECK(deformable_N[i] == Approx(expected_N).epsilon(1e-9));
    CHECK(rigid_N[i] == Approx(expected_N).epsilon(1e-9));
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("a run cut short by max_steps is marked incomplete with the steps it did", "[fem]") {
  const study::Study study = smallQuickStudy();
  const auto out = std::filesystem::temp_directory_path() / "demfem-driver-truncated-test";
  std::filesystem::remove_all(out);
  auto dem = adapter::makeTestBackend("constant", study.tools, adapter::TestLoad{});
  fem::CoupledRunOptions options;
  options.output_dir = out;
  const auto plan = study::planToolMotion(study, study.tools[0]);
  options.max_steps = plan.insertion_steps + 7;
  const auto summary = fem::CoupledDriver(study, options).run(*dem);
  const std::string reason = "stopped after " + std::to_string(plan.insertion_steps + 7) + " of " +
                             std::to_string(plan.totalSteps()) + " FEM steps";
  CHECK_FALSE(summary.complete);
  CHECK(summary.incomplete_reason == reason);
  std::ifstream in(out / "sensors.json");
  const auto sidecar = nlohmann::json::parse(in);
  CHECK(sidecar["complete"] == false);
  CHECK(sidecar["incomplete_reason"] == reason);
  CHECK(sidecar["steps"] == plan.insertion_steps + 7);
  CHECK(sidecar["planned_steps"] == plan.totalSteps());
  std::ifstream csv(out / "sensors.csv");
  std::stringstream text;
  text << csv.rdbuf();
  CHECK(text.str().find("\n# incomplete: " + reason + "\n") != std::string::npos);
  std::filesystem::remove_all(out);
}

TEST_CASE("a resume from an edited FEM checkpoint is refused before anything changes", "[fem]") {
  // fem_state.bin carries the checkpoint container's size and checksum: one edited field (here a
  // byte of the output sizes) used to give a run marked complete with a merged CSV row.
  const study::Study study = smallQuickStudy();
  const auto out = std::filesystem::temp_directory_path() / "demfem-driver-edited-checkpoint-test";
  std::filesystem::remove_all(out);
  std::filesystem::create_directories(out);
  const auto previous = std::filesystem::current_path();
  std::filesystem::current_path(out);  // the test backend keeps its DEM checkpoints here
  fem::CoupledRunOptions options;
  options.output_dir = out / "run";
  options.checkpoint_every = 5;
  const auto plan = study::planToolMotion(study, study.tools[0]);
  options.max_steps = plan.insertion_steps + 7;
  {
    auto dem = adapter::makeTestBackend("harmonic", study.tools, adapter::TestLoad{});
    fem::CoupledDriver(study, options).run(*dem);
  }
  const auto file = options.output_dir / "checkpoint" / "fem_state.bin";
  REQUIRE(std::filesystem::exists(file));
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string csv_before = [&] {
    std::ifstream in(options.output_dir / "sensors.csv");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  bytes[bytes.size() - 20] ^= 0x01;
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  options.resume = true;
  options.max_steps.reset();
  auto dem = adapter::makeTestBackend("harmonic", study.tools, adapter::TestLoad{});
  CHECK_THROWS_WITH(fem::CoupledDriver(study, options).run(*dem), Catch::Contains("fem_state.bin") && Catch::Contains("checksum"));
  std::ifstream in(options.output_dir / "sensors.csv");
  CHECK(std::string(std::istreambuf_iterator<char>(in), {}) == csv_before);
  std::filesystem::current_path(previous);
  std::filesystem::remove_all(out);
}
