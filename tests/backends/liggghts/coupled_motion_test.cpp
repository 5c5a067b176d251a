// The FEM client (fem/coupled_driver.hpp) coupled in-process to the liggghts backend on a small
// deposited bin: the tool's motion has one owner, the plan (study/tool_motion.hpp).
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/study/study.hpp"
#include "demfem/study/tool_motion.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

using namespace demfem;
namespace fs = std::filesystem;

namespace {

// studies/quick_liggghts.json made small: a 140 x 80 mm bin filled 40 mm deep, a 120 x 20 mm tool
// off the centre line (x = 30 mm), inserted at 300 mm/s and dragged 10 mm at 100 mm/s (95 + 100
// FEM steps of 1 ms).
study::Study smallCoupledStudy() {
  std::ifstream in(fs::path(DEMFEM_SOURCE_DIR) / "studies" / "quick_liggghts.json");
  std::stringstream text;
  text << in.rdbuf();
  auto doc = nlohmann::json::parse(text.str());
  doc["soil"]["bin"]["length_mm"] = 140;
  doc["soil"]["bin"]["width_mm"] = 80;
  doc["soil"]["fill_height_mm"] = 40;
  doc["soil"]["layers"][3]["bottom_depth_mm"] = 40;
  doc["soil"]["deposition"]["backend"] = "liggghts";  // a LIGGGHTS-only test: LIGGGHTS deposits its soil
  auto& tool = doc["tools"][0];
  tool["geometry"]["length_mm"] = 120;
  tool["geometry"]["width_mm"] = 20;
  tool["motion"]["insertion_velocity_mm_s"] = 300;
  tool["motion"]["velocity_mm_s"] = 100;
  tool["motion"]["stroke_mm"] = 10;
  tool["motion"]["start_z_mm"] = 40;
  tool["motion"]["center_x_mm"] = 30;
  doc["dem"]["backend"] = "liggghts";
  return study::parseStudy(doc.dump(), "quick_liggghts.json (small bin, coupled motion test)");
}

// Forwards to the backend; after every simulate() records the tool tip's bin height (the rigid
// motion at the DEM clock) and how far the mesh LIGGGHTS moved is from where that motion and the
// last positions put it (nodePositions() is the mesh minus the rigid motion).
class MotionRecorder final : public adapter::CouplingApi {
 public:
  MotionRecorder(adapter::CouplingApi& dem, std::string tool) : dem_(dem), tool_(std::move(tool)), set_(dem.nodePositions(tool_)) {
    record();
  }
  std::vector<double> heights_m;
  double largest_mesh_offset_m = 0;

  adapter::BackendInfo info() override { return dem_.info(); }
  std::vector<adapter::GeometryInfo> geometries() override { return dem_.geometries(); }
  double time() override { return dem_.time(); }
  adapter::NodeArray nodePositions(const std::string& g) override { return dem_.nodePositions(g); }
  adapter::NodeArray nodeForces(const std::string& g, adapter::ForceMode m) override { return dem_.nodeForces(g, m); }
  void setNodePositions(const std::string& g, const adapter::NodeArray& x) override {
    dem_.setNodePositions(g, x);
    set_ = x;
  }
  void simulate(double d) override {
    dem_.simulate(d);
    record();
  }
  adapter::RigidMotion rigidMotion(const std::string& g) override { return dem_.rigidMotion(g); }
  void setRigidMotion(const std::string& g, const adapter::RigidMotion& m) override { dem_.setRigidMotion(g, m); }
  void checkpoint(const fs::path& f) override { dem_.checkpoint(f); }
  void restore(const fs::path& f) override { dem_.restore(f); }
  void shutdown() override { dem_.shutdown(); }

 private:
  void record() {
    const auto m = dem_.rigidMotion(tool_);
    heights_m.push_back(m.origin_m[1] + m.velocity_m_s[1] * (dem_.time() - m.t0_s));
    const auto xyz = dem_.nodePositions(tool_);
    for (std::size_t v = 0; v < xyz.size(); ++v) largest_mesh_offset_m = std::max(largest_mesh_offset_m, std::abs(xyz[v] - set_[v]));
  }
  adapter::CouplingApi& dem_;
  std::string tool_;
  adapter::NodeArray set_;
};

}  // namespace

TEST_CASE("a coupled run on LIGGGHTS moves the tool once: down from the plan's start to the depth, never up",
          "[liggghts][fem][physics]") {
  const fs::path dir = fs::temp_directory_path() / ("demfem-liggghts-motion-" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
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

  MotionRecorder dem(*backend, study.tools[0].name);
  fem::CoupledRunOptions options;
  options.output_dir = dir / "out";
  const auto summary = fem::CoupledDriver(study, options).run(dem);
  CHECK(summary.complete);
  REQUIRE(dem.heights_m.size() == static_cast<std::size_t>(1 + plan.totalSteps()));
  const double depth_y = study.soil.fill_height_m - study.tools[0].motion.depth_m;
  int arrivals = 0;
  for (std::size_t k = 1; k < dem.heights_m.size(); ++k) {
    INFO("after FEM step " << k);
    CHECK(dem.heights_m[k] <= dem.heights_m[k - 1] + 1e-15);
    if (std::abs(dem.heights_m[k] - depth_y) < 1e-12 && std::abs(dem.heights_m[k - 1] - depth_y) >= 1e-12) {
      ++arrivals;
      CHECK(k == static_cast<std::size_t>(plan.insertion_steps));
    }
  }
  CHECK(arrivals == 1);
  CHECK(dem.heights_m.back() == Approx(depth_y).margin(1e-12));
  // LIGGGHTS moved its mesh by that motion and no other: its nodes minus the rigid motion are the
  // positions the FEM client set (1e-9 m: LIGGGHTS integrates the mesh velocity step by step).
  CHECK(dem.largest_mesh_offset_m < 1e-9);
  fs::remove_all(dir);
}
