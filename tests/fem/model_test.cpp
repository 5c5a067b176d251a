// FEM model tests: bending without locking (Euler-Bernoulli), exactness of the keypoint reduction
// (Eq 11-15), the paper's constraint rule, sensors and keypoint matching.
#include "fem_test_tools.hpp"

#include "demfem/adapter/plate_surface.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

using namespace demfem;
using namespace demfem::fem;


TEST_CASE("a long thin clamped strip under a tip load bends as Euler-Bernoulli predicts", "[fem]") {
  // 340 x 10 x 4 mm steel strip, clamped over the top 40 mm: free length 300 mm, L/h = 75. The
  // load-cell line is put on the clamp edge so it adds nothing. One Hex20 element through the 4 mm
  // thickness, 5 mm in plane, as in the paper's grid. Tolerance 2 %; shear deformation
  // adds (E/kG)(h/L)^2/4 ~ 1e-4 and the clamp's Poisson restraint a little more.
  const study::Tool strip = testing::eulerBernoulliStrip();
  for (HexIntegration integration : {HexIntegration::Reduced, HexIntegration::Full}) {
    const ReducedModel model = reduce(buildPlateModel(strip, integration));
    const double F = 1.0, L = 0.300;
    const double I = strip.geometry.width_m * std::pow(strip.geometry.thickness_m, 3) / 12;
    const double expected = F * L * L * L / (3 * strip.fem.youngs_Pa * I);
    const StaticSolution s = solveStatic(model, testing::tipLoad(model, F));
    CHECK(-testing::tipDeflection(model, s.displacement) == Approx(expected).epsilon(0.02));
  }
}

TEST_CASE("the plate mesh shares node ids and positions with the DEM keypoint surface", "[fem]") {
  const study::Tool tool = testing::pmmaTool();
  const auto surface = adapter::makePlateSurface(0.2, 0.04, 0.004, 0.005);
  const FullModel full = buildPlateModel(tool);
  REQUIRE(full.keypoint_nodes.size() == surface.nodes.size());
  REQUIRE(full.keypoints.rows() == 738);  // 41 x 9 x 2 grid nodes, all on the surface
  for (std::size_t k = 0; k < surface.nodes.size(); ++k)
    for (int d = 0; d < 3; ++d) CHECK(full.keypoints(static_cast<Eigen::Index>(k), d) == Approx(surface.nodes[k][d]).margin(1e-15));
  // Section 2.9 constraints: 9 rows x 18 keypoints clamped (y >= 160 mm), 9 load-cell keypoints at
  // y = 135 mm on the back face.
  CHECK(full.constraints.fixed_dofs.size() == 9 * 18 * 3 + 9);
  CHECK(full.constraints.load_cell_dofs.size() == 9);
}

TEST_CASE("the reduced static response at the keypoints equals the full model's", "[fem]") {
  testing::checkReducedStaticEqualsFull(testing::smallStrip());
}

TEST_CASE("the reduced first frequency is within 0.5 % of the full one and never below it", "[fem]") {
  testing::checkReducedFrequencies(testing::smallStrip());
}

TEST_CASE("constraints off the keypoints are rejected with a message naming them", "[fem]") {
  SECTION("a load-cell line between keypoint rows") {
    study::Tool tool = testing::pmmaTool();
    tool.constraints.load_cell_from_top_m = 0.0675;  // y = 132.5 mm: only mid-side nodes there
    CHECK_THROWS_WITH(buildPlateModel(tool), Catch::Contains("load-cell line") && Catch::Contains("y = 0.1325 m") &&
                                                 Catch::Contains("y = 0.13 m") && Catch::Contains("y = 0.135 m"));
  }
  SECTION("a constrained mid-side node") {
    FullModel full = buildPlateModel(testing::steelTool());
    // Node 1 of the half-step lattice is the mid-side node between keypoints 0 and 1 of the tip row.
    full.constraints.fixed_dofs.push_back(3 * 1 + 2);
    std::sort(full.constraints.fixed_dofs.begin(), full.constraints.fixed_dofs.end());
    CHECK_THROWS_WITH(reduce(full), Catch::Contains("1 constrained DOF(s) are not keypoint DOFs") &&
                                        Catch::Contains("node 1 (-0.0175, 0, -0.0015) m DOF z"));
  }
}

TEST_CASE("sensors read deformation by row interpolation, tip tilt by slope and the load cell by reactions", "[fem]") {
  study::Tool tool = testing::pmmaTool();
  tool.geometry.width_m = 0.010;  // narrow: a quick reduction, same rows along y as the PMMA tool
  const ReducedModel model = reduce(buildPlateModel(tool));
  const Sensors sensors(model, tool);
  // A linear field -u_z = a + b y: the sensor at y = 107 mm reads a + b 0.107 exactly; the tip
  // slope of -u_z is -b (deflection grows toward the tip for b < 0).
  const double a = 2e-3, b = -5e-3;
  Eigen::VectorXd u = Eigen::VectorXd::Zero(model.dofCount());
  for (int k = 0; k < model.keypointCount(); ++k) u(3 * k + 2) = -(a + b * model.keypoints(k, 1));
  Eigen::VectorXd reactions = Eigen::VectorXd::Zero(model.dofCount());
  for (int dof : model.constraints.load_cell_dofs) reactions(dof) = 0.25;
  const SensorReadings s = sensors.read(u, reactions);
  CHECK(s.deformation_mm == Approx(1000 * (a + b * 0.107)).epsilon(1e-12));
  CHECK(s.tip_tilt_deg == Approx(std::atan(-b) * 180 / std::numbers::pi).epsilon(1e-12));
  CHECK(s.load_cell_N == Approx(0.25 * 3).epsilon(1e-12));  // 3 load-cell keypoints across 10 mm
  // A load against travel at the tip: every sensor positive (documented sign convention).
  const StaticSolution st = solveStatic(model, testing::tipLoad(model, 1.0));
  const SensorReadings loaded = sensors.read(st.displacement, st.reaction);
  CHECK(loaded.load_cell_N > 1.0);  // lever: the load cell is between load and clamp
  CHECK(loaded.deformation_mm > 0);
  CHECK(loaded.tip_tilt_deg > 0);
}

TEST_CASE("keypoints received from a DEM backend are matched by position or rejected", "[fem]") {
  const ReducedModel model = reduce(buildPlateModel(testing::smallStrip()));
  const int n = model.keypointCount();
  std::vector<double> received(3 * static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const int k = (5 * i + 3) % n;  // a permutation (5 and 126 are coprime)
    for (int d = 0; d < 3; ++d) received[3 * i + d] = model.keypoints(k, d) + 1e-9 * (d + 1);
  }
  const std::vector<int> match = matchKeypoints(model, received, 1e-6);
  for (int i = 0; i < n; ++i) CHECK(match[static_cast<std::size_t>(i)] == (5 * i + 3) % n);
  received[5 * 3 + 1] += 0.001;
  CHECK_THROWS_WITH(matchKeypoints(model, received, 1e-6), Catch::Contains("DEM node 5"));
  received.resize(received.size() - 3);
  CHECK_THROWS_WITH(matchKeypoints(model, received, 1e-6), Catch::Contains("the FEM model has 126 keypoints"));
}
