// The modal integration (fem/modal.hpp) against the full three-level integration of Eq (5)-(10)
// (ThreeLevelIntegrator, itself checked against closed forms in integrator_test.cpp), and the spring
// Ritz basis against the direct eigen and static solutions of each clamp spring.
#include "fem_test_tools.hpp"

#include "demfem/adapter/test_backends.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/fem/integrator.hpp"
#include "demfem/fem/modal.hpp"
#include "demfem/fem/sensors.hpp"
#include "demfem/study/tool_motion.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

using namespace demfem;
using namespace demfem::fem;

namespace {

// A 120 x 20 x 4 mm PMMA tool (the paper's material and damping, Table 3) on the 5 mm grid.
study::Tool smallPmmaTool() {
  study::Tool t = testing::pmmaTool();
  t.geometry.length_m = 0.120;
  t.geometry.width_m = 0.020;
  return t;
}

// Largest |a - b| over the run relative to the largest |b|, per channel.
struct Deviation {
  double force = 0, deformation = 0;
};

struct Channels {
  std::vector<double> force, deformation;
};

Deviation deviation(const Channels& a, const Channels& b) {
  REQUIRE(a.force.size() == b.force.size());
  double range_f = 0, range_d = 0, df = 0, dd = 0;
  for (std::size_t i = 0; i < a.force.size(); ++i) {
    range_f = std::max(range_f, std::abs(b.force[i]));
    range_d = std::max(range_d, std::abs(b.deformation[i]));
    df = std::max(df, std::abs(a.force[i] - b.force[i]));
    dd = std::max(dd, std::abs(a.deformation[i] - b.deformation[i]));
  }
  return {df / range_f, dd / range_d};
}

// A DEM-like load: contacts on the front-face keypoints of the lowest 20 mm, each switching on and
// off and fluctuating from step to step (white noise on a growing mean), so every mode is excited.
std::vector<Eigen::VectorXd> contactLoads(const ReducedModel& model, int steps) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<int> front;
  for (int k = 0; k < model.keypointCount(); ++k)
    if (model.keypoints(k, 1) <= 0.020 + 1e-9 && model.keypoints(k, 2) > 0) front.push_back(k);
  std::vector<Eigen::VectorXd> loads;
  for (int i = 0; i < steps; ++i) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(model.dofCount());
    const double mean = 0.5 * std::min(1.0, i / 100.0);
    for (int k : front) {
      if (unit(rng) < 0.4) continue;  // no contact on this keypoint in this interval
      f(3 * k + 2) = -mean * (0.5 + unit(rng));
      f(3 * k + 1) = 0.3 * mean * (unit(rng) - 0.5);
    }
    loads.push_back(f);
  }
  return loads;
}

Channels run(TimeIntegrator& integrator, const Sensors& sensors, const std::vector<Eigen::VectorXd>& loads) {
  Channels c;
  integrator.start(loads.front());
  for (const auto& f : loads) {
    const Eigen::VectorXd& u = integrator.step(f);
    const SensorReadings r = sensors.read(u, integrator.reactions());
    c.force.push_back(r.load_cell_N);
    c.deformation.push_back(r.deformation_mm);
  }
  return c;
}

}  // namespace

TEST_CASE("the modal integration gives the full integration's load cell and deformation within 0.1 % under contact noise", "[fem]") {
  const study::Tool tool = smallPmmaTool();
  const ReducedModel model = reduce(buildFullModel(tool));
  const double dt = 1e-3;  // Table 3 dt_FEM
  const RayleighDamping damping{tool.fem.alpha_s, tool.fem.beta_per_s};
  const Sensors sensors(model, tool);
  const auto loads = contactLoads(model, 600);
  ThreeLevelIntegrator full(model, dt, damping);
  ModalIntegrator modal(model, dt, damping);
  // Modes up to w dt = 30, far fewer than the free DOFs.
  CHECK(2 * M_PI * modal.highestModeHz() * dt <= kQuasiStaticOmegaDt);
  CHECK(modal.modeCount() < static_cast<int>(model.freeDofs().size()) / 20);
  const Deviation d = deviation(run(modal, sensors, loads), run(full, sensors, loads));
  CHECK(d.force < 1e-3);
  CHECK(d.deformation < 1e-3);
}

TEST_CASE("the modal integration at rest under a constant load is the static solution from the first step", "[fem]") {
  const study::Tool tool = smallPmmaTool();
  const ReducedModel model = reduce(buildFullModel(tool));
  const Sensors sensors(model, tool);
  const Eigen::VectorXd f = testing::tipLoad(model, 3.0);
  const StaticSolution exact = solveStatic(model, f);
  const SensorReadings expected = sensors.read(exact.displacement, exact.reaction);
  ModalIntegrator modal(model, 1e-3, {tool.fem.alpha_s, tool.fem.beta_per_s});
  modal.start(f);
  for (int i = 0; i < 5; ++i) {
    const SensorReadings r = sensors.read(modal.step(f), modal.reactions());
    CHECK(r.load_cell_N == Approx(expected.load_cell_N).epsilon(1e-8));
    CHECK(r.deformation_mm == Approx(expected.deformation_mm).epsilon(1e-8));
  }
  CHECK((modal.displacement() - exact.displacement).norm() < 1e-8 * exact.displacement.norm());
}

TEST_CASE("a saved modal integration state resumes the run bit for bit", "[fem]") {
  const study::Tool tool = smallPmmaTool();
  const ReducedModel model = reduce(buildFullModel(tool));
  const auto loads = contactLoads(model, 40);
  ModalIntegrator a(model, 1e-3, {tool.fem.alpha_s, 0});
  a.start(loads.front());
  for (int i = 0; i < 20; ++i) a.step(loads[static_cast<std::size_t>(i)]);
  const SavedIntegratorState saved = a.save();
  ModalIntegrator b(model, 1e-3, {tool.fem.alpha_s, 0});
  b.restore(saved);
  for (int i = 20; i < 40; ++i) {
    const Eigen::VectorXd ua = a.step(loads[static_cast<std::size_t>(i)]);
    const Eigen::VectorXd ub = b.step(loads[static_cast<std::size_t>(i)]);
    REQUIRE(ua == ub);
    REQUIRE(a.reactions() == b.reactions());
  }
  ThreeLevelIntegrator full(model, 1e-3, {tool.fem.alpha_s, 0});
  CHECK_THROWS_WITH(b.restore(full.save()), Catch::Contains("not the state of a modal integration"));
}

namespace {

study::Study smallQuickStudy(const std::string& integration) {
  std::ifstream in(std::filesystem::path(DEMFEM_SOURCE_DIR) / "studies" / "quick.json");
  std::stringstream text;
  text << in.rdbuf();
  auto doc = nlohmann::json::parse(text.str());
  doc["tools"][0]["geometry"]["length_mm"] = 120;
  doc["tools"][0]["geometry"]["width_mm"] = 20;
  doc["fem"]["integration"] = integration;
  return study::parseStudy(doc.dump(), "quick.json (small tool, " + integration + " integration)");
}

// Columns force_N and deformation_mm of a run's sensors.csv.
Channels sensorColumns(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  REQUIRE(line == "t_s,displacement_mm,force_N,deformation_mm,tilt_deg");
  Channels c;
  while (std::getline(in, line)) {
    if (line[0] == '#') continue;
    std::vector<double> v;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) v.push_back(std::stod(cell));
    c.force.push_back(v.at(2));
    c.deformation.push_back(v.at(3));
  }
  return c;
}

Channels harmonicRun(const std::string& integration, const std::filesystem::path& out) {
  const study::Study study = smallQuickStudy(integration);
  adapter::TestLoad load;
  load.frequency_Hz = 45;  // near the small tool's first mode: a strongly dynamic response
  auto dem = adapter::makeTestBackend("harmonic", study.tools, load);
  CoupledRunOptions options;
  options.output_dir = out;
  options.max_steps = study::planToolMotion(study, study.tools[0]).insertion_steps + 300;
  CoupledDriver(study, options).run(*dem);
  return sensorColumns(out / "sensors.csv");
}

}  // namespace

TEST_CASE("the coupled driver integrates modally by default and matches fem.integration full within 0.1 %", "[fem]") {
  CHECK(smallQuickStudy("modal").fem.integration == study::FemIntegration::Modal);
  const auto dir = std::filesystem::temp_directory_path() / "demfem-modal-driver-test";
  std::filesystem::remove_all(dir);
  const Deviation d = deviation(harmonicRun("modal", dir / "modal"), harmonicRun("full", dir / "full"));
  CHECK(d.force < 1e-3);
  CHECK(d.deformation < 1e-3);
  std::filesystem::remove_all(dir);
}

TEST_CASE("the spring Ritz basis gives every clamp spring's modes and static solution without a new eigen solution", "[fem]") {
  // The strip's free part has EI/L = 138 N m/rad; the diagnosis starts its clamp spring at
  // 1000 EI/L and searches down to 0.1 EI/L (campaign/src/diagnose_causes.cpp).
  study::Tool tool = testing::smallStrip();
  const double k_ref = 1.4e5;
  tool.constraints.clamp_rotational_stiffness_Nm_per_rad = k_ref;
  const ReducedModel reference = reduce(buildFullModel(tool));
  const SpringRitzBasis ritz(reference, 20);
  const Eigen::VectorXd f = testing::tipLoad(reference, 2.0);
  for (const auto& [e, k] : {std::pair{1.0, k_ref}, {1.2, 3e3}, {0.8, 14.0}}) {
    study::Tool changed = tool;
    changed.fem.youngs_Pa *= e;
    changed.constraints.clamp_rotational_stiffness_Nm_per_rad = k;
    const ReducedModel direct_model = reduce(buildFullModel(changed));
    const Modes direct = naturalModes(direct_model, 12);
    const Modes projected = ritz.modes(e, k / k_ref, 12);
    for (int j = 0; j < 12; ++j)
      CHECK(projected.frequencies_Hz[static_cast<std::size_t>(j)] ==
            Approx(direct.frequencies_Hz[static_cast<std::size_t>(j)]).epsilon(1e-6));
    const StaticSolution exact = solveStatic(direct_model, f);
    const StaticSolution woodbury = ritz.solveStatic(e, k / k_ref, f);
    CHECK((woodbury.displacement - exact.displacement).norm() < 1e-7 * exact.displacement.norm());
    CHECK((woodbury.reaction - exact.reaction).norm() < 1e-7 * exact.reaction.norm());
  }
}
