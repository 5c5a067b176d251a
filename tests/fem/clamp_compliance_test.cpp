// The compliant clamp (docs/fem.md, fem/model.hpp): a rotational spring at the clamp's lower edge,
// checked against the closed forms of an Euler-Bernoulli beam with a rotational spring at the root.
#include "fem_test_tools.hpp"

#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace demfem;
using namespace demfem::fem;

namespace {

double bendingStiffness(const study::Tool& tool) {
  return tool.fem.youngs_Pa * tool.geometry.width_m * std::pow(tool.geometry.thickness_m, 3) / 12;
}

// Load-cell force of a beam with a root spring k (x = 0: w = 0, M = k w'), a prop at x = a (w = 0)
// and a tip load P at x = L: the prop's force makes w(a) = 0,
//   P a^2 (3L - a) / (6 EI) + P L a / k = R (a^3 / (3 EI) + a^2 / k).
double proppedReaction(double P, double L, double a, double EI, double k) {
  return P * (a * a * (3 * L - a) / (6 * EI) + L * a / k) / (a * a * a / (3 * EI) + a * a / k);
}

}  // namespace

TEST_CASE("a cantilever on a rotational clamp spring deflects by F L^3 / 3EI + F L^2 / k", "[fem]") {
  // 340 x 10 x 4 mm steel strip, free length 300 mm (L/h = 75) as in the rigid clamp's
  // Euler-Bernoulli test; the load-cell line on the clamp edge adds nothing. Tolerance 2 % as there.
  study::Tool strip = testing::eulerBernoulliStrip();
  const double F = 1.0, L = 0.300, EI = bendingStiffness(strip);
  for (double factor : {1.0, 10.0}) {
    const double k = factor * EI / L;
    strip.constraints.clamp_rotational_stiffness_Nm_per_rad = k;
    const FullModel full = buildPlateModel(strip);
    REQUIRE_FALSE(full.constraints.springs.empty());
    const ReducedModel model = reduce(full);
    const StaticSolution s = solveStatic(model, testing::tipLoad(model, F));
    const double expected = F * L * L * L / (3 * EI) + F * L * L / k;
    CHECK(-testing::tipDeflection(model, s.displacement) == Approx(expected).epsilon(0.02));
  }
}

TEST_CASE("a compliant clamp moves the load onto the load cell as the propped-beam closed form says", "[fem]") {
  // A 10 mm wide strip held like the paper's tools (clamp 40 mm, load cell 65 mm and sensor 93 mm
  // below the top, free length 160 mm): with a rigid clamp the load cell carries (3L - a) / 2a =
  // 9.1 times the tip load, with a pinned one L / a = 6.4 times. Tolerance 3 %: the 3D plate
  // differs from the beam by shear and by the clamp's own 3D restraint.
  study::Tool strip = testing::steelTool();
  strip.geometry.width_m = 0.010;
  strip.geometry.thickness_m = 0.004;
  const double F = 1.0, L = 0.160, a = 0.025, EI = bendingStiffness(strip);
  for (double factor : {0.3, 3.0}) {
    const double k = factor * EI / L;
    strip.constraints.clamp_rotational_stiffness_Nm_per_rad = k;
    const ReducedModel model = reduce(buildPlateModel(strip));
    const StaticSolution s = solveStatic(model, testing::tipLoad(model, F));
    const SensorReadings reading = Sensors(model, strip).read(s.displacement, s.reaction);
    CHECK(reading.load_cell_N == Approx(proppedReaction(F, L, a, EI, k)).epsilon(0.03));
  }
  SECTION("a very stiff spring gives the rigid clamp's load-cell force within 3 %") {
    // The rigid clamp fixes every keypoint of the top 40 mm, the spring only the edge section's:
    // the 3D restraint differs by about 2 % in the load-cell force.
    strip.constraints.clamp_rotational_stiffness_Nm_per_rad = 1e4 * EI / L;
    const ReducedModel sprung = reduce(buildPlateModel(strip));
    strip.constraints.clamp_rotational_stiffness_Nm_per_rad.reset();
    const ReducedModel rigid = reduce(buildPlateModel(strip));
    const auto force = [&](const ReducedModel& m) {
      const StaticSolution s = solveStatic(m, testing::tipLoad(m, F));
      return Sensors(m, strip).read(s.displacement, s.reaction).load_cell_N;
    };
    CHECK(force(sprung) == Approx(force(rigid)).epsilon(0.03));
    CHECK(force(sprung) < force(rigid));
  }
}

TEST_CASE("sensor gains scale the load-cell and deformation channels only", "[fem]") {
  study::Tool strip = testing::smallStrip();
  const ReducedModel model = reduce(buildPlateModel(strip));
  const StaticSolution s = solveStatic(model, testing::tipLoad(model, 1.0));
  const SensorReadings ideal = Sensors(model, strip).read(s.displacement, s.reaction);
  strip.sensors.force_gain = 0.9;
  strip.sensors.deformation_gain = 1.2;
  const SensorReadings scaled = Sensors(model, strip).read(s.displacement, s.reaction);
  CHECK(scaled.load_cell_N == Approx(0.9 * ideal.load_cell_N).epsilon(1e-12));
  CHECK(scaled.deformation_mm == Approx(1.2 * ideal.deformation_mm).epsilon(1e-12));
  CHECK(scaled.tip_tilt_deg == Approx(ideal.tip_tilt_deg).epsilon(1e-12));
}
