// The modal integration (fem/modal.hpp) against the full three-level integration of Eq (5)-(10)
// (ThreeLevelIntegrator, itself checked against closed forms in integrator_test.cpp), and the spring
// Ritz basis against the direct eigen and static solutions of each clamp spring.
#include "fem_test_tools.hpp"
#include "support/small_study.hpp"
#include "test_backend_run.hpp"

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

TEST_CASE("the modal step projects any number of loaded DOFs: 1 to 9 give the full integration's response, superposed exactly", "[fem]") {
  // The step takes the loaded columns four at a time and the rest one by one (fem/src/modal.cpp):
  // every remainder of 4 is run against the full integration and against the sum of the responses
  // to each loaded DOF alone (linearity: equal to round-off).
  const study::Tool tool = smallPmmaTool();
  const ReducedModel model = reduce(buildFullModel(tool));
  const RayleighDamping damping{tool.fem.alpha_s, tool.fem.beta_per_s};
  const Sensors sensors(model, tool);
  ThreeLevelIntegrator full(model, 1e-3, damping);
  ModalIntegrator modal(model, 1e-3, damping);
  std::vector<int> front;  // z DOFs of the front face's lowest 20 mm, tip first
  for (int k = 0; k < model.keypointCount(); ++k)
    if (model.keypoints(k, 1) <= 0.020 + 1e-9 && model.keypoints(k, 2) > 0) front.push_back(3 * k + 2);
  REQUIRE(front.size() >= 9);
  // A step load switched on at t = 0 plus a 150 Hz fluctuation, different on each DOF.
  const auto load = [&](const std::vector<int>& dofs, int step) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(model.dofCount());
    for (std::size_t j = 0; j < dofs.size(); ++j)
      f(dofs[j]) = -0.5 - 0.2 * std::sin(2 * M_PI * 150 * 1e-3 * step + static_cast<double>(j));
    return f;
  };
  const int steps = 80;
  const auto response = [&](TimeIntegrator& integrator, const std::vector<int>& dofs) {
    std::vector<Eigen::VectorXd> u;
    std::vector<double> force;
    integrator.start(Eigen::VectorXd::Zero(model.dofCount()));
    for (int i = 1; i <= steps; ++i) {
      u.push_back(integrator.step(load(dofs, i)));
      force.push_back(sensors.read(u.back(), integrator.reactions()).load_cell_N);
    }
    return std::pair{u, force};
  };
  for (std::size_t count = 1; count <= 9; ++count) {
    CAPTURE(count);
    const std::vector<int> dofs(front.begin(), front.begin() + static_cast<std::ptrdiff_t>(count));
    const auto [u_modal, f_modal] = response(modal, dofs);
    const auto [u_full, f_full] = response(full, dofs);
    double u_max = 0, u_dev = 0, f_max = 0, f_dev = 0;
    for (int i = 0; i < steps; ++i) {
      u_max = std::max(u_max, u_full[static_cast<std::size_t>(i)].cwiseAbs().maxCoeff());
      u_dev = std::max(u_dev, (u_modal[static_cast<std::size_t>(i)] - u_full[static_cast<std::size_t>(i)]).cwiseAbs().maxCoeff());
      f_max = std::max(f_max, std::abs(f_full[static_cast<std::size_t>(i)]));
      f_dev = std::max(f_dev, std::abs(f_modal[static_cast<std::size_t>(i)] - f_full[static_cast<std::size_t>(i)]));
    }
    CHECK(u_dev < 1e-3 * u_max);
    CHECK(f_dev < 1e-3 * f_max);
    // Superposition: the DOFs one at a time (each with its own fluctuation phase).
    std::vector<Eigen::VectorXd> u_sum(steps, Eigen::VectorXd::Zero(model.dofCount()));
    std::vector<double> f_sum(steps, 0.0);
    for (std::size_t j = 0; j < count; ++j) {
      modal.start(Eigen::VectorXd::Zero(model.dofCount()));
      for (int i = 1; i <= steps; ++i) {
        Eigen::VectorXd f = Eigen::VectorXd::Zero(model.dofCount());
        f(dofs[j]) = load(dofs, i)(dofs[j]);
        u_sum[static_cast<std::size_t>(i - 1)] += modal.step(f);
        f_sum[static_cast<std::size_t>(i - 1)] += sensors.read(modal.displacement(), modal.reactions()).load_cell_N;
      }
    }
    for (int i = 0; i < steps; ++i) {
      CHECK((u_sum[static_cast<std::size_t>(i)] - u_modal[static_cast<std::size_t>(i)]).cwiseAbs().maxCoeff() < 1e-12 * u_max);
      CHECK(std::abs(f_sum[static_cast<std::size_t>(i)] - f_modal[static_cast<std::size_t>(i)]) < 1e-12 * f_max);
    }
  }
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
  auto doc = demfem::support::shippedStudyJson("quick.json");
  demfem::support::useSmallTool(doc);
  doc["fem"]["integration"] = integration;
  return study::parseStudy(doc.dump(), "quick.json (small tool, " + integration + " integration)");
}

// Columns force_N and deformation_mm of the run's sensors.csv, on the harmonic test backend.
Channels harmonicRun(const std::string& integration, const std::filesystem::path& out) {
  const study::Study study = smallQuickStudy(integration);
  adapter::TestLoad load;
  load.frequency_Hz = 45;  // near the small tool's first mode: a strongly dynamic response
  testing::runOnTestBackend(study, "harmonic", load, out, 300);
  const testing::SensorColumns c = testing::readSensorColumns(out / "sensors.csv");
  REQUIRE(c.header == "t_s,displacement_mm,force_N,deformation_mm,tilt_deg");
  return {c.force, c.deformation};
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
