// The study's DEM step (backends/physics/time_step.hpp) against closed forms written out here: a
// two-sphere contact's duration pi sqrt(m*/k) for LIGGGHTS hooke and for the EDEM hysteretic
// spring's unloading branch, the paper's 7.93e-7 s as 20 % of Rayleigh's estimate, and an explicit
// step kept as given with its margin to the stiffest spring.
#include "demfem/backends/physics/time_step.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

using namespace demfem;
using Catch::Detail::Approx;

namespace {

constexpr double kRadius = 0.00475;  // the paper's smallest particle (9.5 mm)

// One particle material "grain" (the paper's Table 2 values), bin and tool walls of "wall".
study::Study twoMaterialStudy(const study::DemMaterial& wall, double wall_restitution) {
  study::Study s;
  s.soil.diameter_min_m = 2 * kRadius;
  s.soil.materials = {{"grain", 2600, 1.118e11, 0.3, 5.88e5}, wall};
  s.soil.bin_material = wall.name;
  s.soil.layers = {{"grain", 0, s.soil.fill_height_m}};
  s.soil.interactions = {{"grain", "grain", 0.5, 0.5, 0, 0}, {"grain", wall.name, wall_restitution, 0.5, 0, 0}};
  study::Tool tool;
  tool.dem_material = wall.name;
  s.tools = {tool};
  s.dem.criterion = study::TimeStepCriterion::StiffestSpring;
  s.dem.dt_fraction = 0.1;
  return s;
}

double mass() { return 2600 * 4.0 / 3.0 * std::numbers::pi * kRadius * kRadius * kRadius; }

}  // namespace

TEST_CASE("hooke: the critical step is the two-sphere contact duration pi sqrt(m*/kn)", "[dem_physics]") {
  // Walls of the grain's own material: the particle-particle contact (R* = R/2, m* = m/2) is the
  // stiffest relative to its mass, since m*/kn goes as m*^0.8 R*^-0.4.
  study::Study s = twoMaterialStudy({"wall", 2600, 1.118e11, 0.3, 0}, 0.5);
  s.soil.contact.normal = study::NormalModel::Hooke;
  s.soil.contact.characteristic_velocity_m_s = 0.5;
  const double y_eff = 1.118e11 / (2 * (1 - 0.09)), r_eff = kRadius / 2, m_eff = mass() / 2, v = 0.5;
  const double kn = 16.0 / 15.0 * std::sqrt(r_eff) * y_eff * std::pow(15.0 * m_eff * v * v / (16.0 * std::sqrt(r_eff) * y_eff), 0.2);
  const physics::CriticalStep c = physics::criticalStep(s, study::TimeStepCriterion::StiffestSpring);
  CHECK(c.step_s == Approx(std::numbers::pi * std::sqrt(m_eff / kn)).epsilon(1e-12));
  CHECK(c.contact == "particle 'grain' - particle 'grain'");
  const physics::DemStep step = physics::demTimeStep(s);
  CHECK(step.step_s == Approx(0.1 * c.step_s).epsilon(1e-12));
  CHECK_THAT(step.why, Catch::Contains("dem.dt_fraction 0.1") && Catch::Contains("particle 'grain' - particle 'grain'"));
  // hooke/hysteresis: the reloading branch k2max = kn * coefficientMaxElasticStiffness.
  s.soil.contact.normal = study::NormalModel::HookeHysteresis;
  s.soil.contact.coefficient_max_elastic_stiffness = 3;
  CHECK(physics::criticalStep(s, study::TimeStepCriterion::StiffestSpring).step_s ==
        Approx(std::numbers::pi * std::sqrt(m_eff / (3 * kn))).epsilon(1e-12));
}

TEST_CASE("EDEM hysteretic: the critical step is the unloading half period pi sqrt(m*/(K1/e^2)), K1 = 5 R* Y", "[dem_physics]") {
  // A wall of yield 0 (not limiting: K1 = 5 R Y of the particle) with the smaller restitution limits.
  const study::Study s = twoMaterialStudy({"steel", 7850, 2e11, 0.3, 0}, 0.4);
  const double k1_wall = 5 * kRadius * 5.88e5, k2_wall = k1_wall / (0.4 * 0.4);
  const physics::CriticalStep c = physics::criticalStep(s, study::TimeStepCriterion::StiffestSpring);
  CHECK(c.stiffness_N_m == Approx(k2_wall).epsilon(1e-12));
  CHECK(c.step_s == Approx(std::numbers::pi * std::sqrt(mass() / k2_wall)).epsilon(1e-12));
  CHECK(c.contact == "particle 'grain' - wall 'steel'");
  // About 0.36 ms for the paper's soil: 460 times the paper's 7.93e-7 s.
  CHECK(c.step_s == Approx(3.63e-4).epsilon(0.01));
}

TEST_CASE("the paper's step is 20 % of Rayleigh's estimate with G = 4.3e10 Pa at R = 4.75 mm", "[dem_physics]") {
  study::Study s = twoMaterialStudy({"steel", 7850, 2e11, 0.3, 0}, 0.5);
  s.dem.criterion = study::TimeStepCriterion::Rayleigh;
  s.dem.dt_fraction = 0.2;
  // E = 2 G (1 + nu) = 1.118e11 Pa; the paper prints 7.93e-7 s (three digits).
  CHECK(physics::demTimeStep(s).step_s == Approx(7.93e-7).epsilon(1e-3));
  CHECK_THAT(physics::demTimeStep(s).why, Catch::Contains("Rayleigh"));
}

TEST_CASE("an explicit dem.dt_s is kept and its margin to the stiffest spring reported", "[dem_physics]") {
  study::Study s = twoMaterialStudy({"steel", 7850, 2e11, 0.3, 0}, 0.4);
  s.dem.dt_s = 7.93e-7;
  const physics::DemStep step = physics::demTimeStep(s);
  CHECK(step.step_s == 7.93e-7);
  CHECK(step.explicit_step);
  CHECK(step.critical_s == physics::criticalStep(s, study::TimeStepCriterion::StiffestSpring).step_s);
  CHECK_THAT(step.why, Catch::Contains("explicit dem.dt_s"));
  s.dem.dt_s.reset();
  s.dem.dt_fraction = 1.5;
  CHECK_THROWS_WITH(physics::demTimeStep(s), Catch::Contains("/dem/dt_fraction"));
}

TEST_CASE("the rolling regularisation step is the DEM step at its fraction, and stays when the DEM step is halved", "[dem_physics]") {
  study::Study s = twoMaterialStudy({"steel", 7850, 2e11, 0.3, 0}, 0.4);
  s.fem.dt_s = 9.2e-4;  // a FEM step the DEM step does not divide: both are shortened alike
  s.dem.dt_fraction = s.soil.contact.rolling_regularisation_fraction;
  const double dem_step = study::demStepDividing(physics::demTimeStep(s).step_s, s.fem.dt_s);
  // The same number, not merely close: at the paper cases' step the law is the one it was before
  // the regularisation had a step of its own.
  CHECK(physics::rollingRegularisationStep(s) == dem_step);
  s.dem.dt_fraction /= 2;
  CHECK(physics::rollingRegularisationStep(s) == dem_step);
  CHECK(study::demStepDividing(physics::demTimeStep(s).step_s, s.fem.dt_s) < 0.51 * dem_step);
  s.soil.contact.rolling_regularisation_fraction = 0;
  CHECK_THROWS_WITH(physics::rollingRegularisationStep(s), Catch::Contains("/soil/contact/rolling_regularisation_fraction"));
}
