// Closed-form checks of the builtin DEM contact laws and wall contacts (docs/builtin-dem.md).
#include "demfem/backends/builtin/contact_law.hpp"
#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/backends/physics/time_step.hpp"
#include "test_soil.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

using namespace demfem;
using namespace demfem::builtin;
using namespace demfem::builtin::testing;

namespace {

constexpr double kR = 0.005;  // sphere radius (m)
constexpr double kG = 9.81;

// Raises gravity smoothly from 0 to g over `ramp` seconds, then holds it for `hold` seconds and
// returns the mean overlap of particle 0 with the plane y = 0 during the hold.
double quasiStaticRestingOverlap(DemSimulation& sim, double ramp, double hold) {
  const double dt = sim.timeStep();
  const long ramp_steps = std::lround(ramp / dt), hold_steps = std::lround(hold / dt);
  for (long s = 0; s < ramp_steps; s += 10) {
    const double g = kG * 0.5 * (1 - std::cos(std::numbers::pi * static_cast<double>(s) / static_cast<double>(ramp_steps)));
    sim.setGravity({0, -g, 0});
    sim.run(10);
  }
  sim.setGravity({0, -kG, 0});
  double sum = 0;
  for (long s = 0; s < hold_steps; ++s) {
    sim.run(1);
    sum += kR - sim.particle(0).x[1];
  }
  return sum / static_cast<double>(hold_steps);
}

constexpr double kRollingFriction = 0.1, kRollingV0 = 0.2;  // m/s

// A sphere resting on the plane y = 0 at its static overlap, rolling without slip along +x at
// kRollingV0 with rolling friction kRollingFriction of the given model; step 1e-5 s.
DemSimulation rollingSphere(study::RollingModel rolling) {
  SoilParameters p;
  p.rolling_friction = kRollingFriction;
  p.model.rolling = rolling;
  const double m = sphereMass(p.density, kR);
  DemSimulation sim(makeSoil(p), box(0.5), 1);
  sim.addPlane({{0, 0, 0}, {0, 1, 0}, 1});
  sim.addParticle({{0, kR - m * kG / (5 * kR * p.yield), 0}, {kRollingV0, 0, 0}, {0, 0, -kRollingV0 / kR}, kR, 0, 0});
  sim.setTimeStep(1e-5);
  return sim;
}

}  // namespace

TEST_CASE("hysteretic spring follows the loading line K1 and the unloading line K2 = K1/e^2", "[builtin]") {
  study::ContactModel model;  // EDEM hysteretic
  PairLaw law;
  law.restitution = 0.5;
  const ContactStiffness s{1000.0, 850.0, 0, 0};  // K1 = 1000 N/m -> K2 = 4000 N/m, delta0 = 0.75 delta_max
  ContactKinematics k{};
  double dmax = 0;
  const auto force = [&](double delta) {
    k.delta = delta;
    return normalForce<study::NormalModel::EdemHysteretic>(model, law, s, k, dmax);
  };
  // Loading: F = K1 delta (exact arithmetic on these numbers up to round-off).
  CHECK(force(0.5e-3) == Approx(0.5).epsilon(1e-12));
  CHECK(force(1.0e-3) == Approx(1.0).epsilon(1e-12));
  // Unloading from delta_max = 1 mm: F = K2 (delta - 0.75 mm).
  CHECK(force(0.9e-3) == Approx(4000 * 0.15e-3).epsilon(1e-12));
  CHECK(force(0.8e-3) == Approx(4000 * 0.05e-3).epsilon(1e-12));
  CHECK(force(0.7e-3) == 0.0);  // below the plastic overlap: no force, history kept
  // Reloading along K2 up to the loading line, then along K1 again.
  CHECK(force(0.95e-3) == Approx(4000 * 0.2e-3).epsilon(1e-12));
  CHECK(force(1.2e-3) == Approx(1.2).epsilon(1e-12));
  CHECK(dmax == 1.2e-3);
}

TEST_CASE("head-on hysteretic collision without viscous damping has restitution e", "[builtin]") {
  for (const double e : {0.3, 0.5, 0.8}) {
    SoilParameters p;
    p.restitution = e;
    p.model.damping_factor = 0;  // the pure Walton-Braun law: hysteresis is the only loss
    DemSimulation sim(makeSoil(p), box(0.1), 1);
    sim.setGravity({0, 0, 0});
    const double v0 = 0.1, gap = 1e-5;
    sim.addParticle({{-kR - gap, 0, 0}, {v0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    sim.addParticle({{kR + gap, 0, 0}, {-v0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    sim.setTimeStep(1e-7);
    sim.run(15000);  // 1.5 ms: approach 0.05 ms, contact about 0.5 ms
    const double separation = sim.particle(1).x[0] - sim.particle(0).x[0];
    REQUIRE(separation > 2 * kR);
    const double e_measured = (sim.particle(1).v[0] - sim.particle(0).v[0]) / (2 * v0);
    // Tolerance: restitution = e within 1e-3.
    CHECK(std::fabs(e_measured - e) < 1e-3);
  }
}

TEST_CASE("at the step the study chooses from its stiffest spring a collision keeps its restitution", "[builtin]") {
  // The step comes from physics::demTimeStep, the one both backends run; two particles of the
  // study's smallest radius meet head on. EDEM hysteretic (no viscous part) and LIGGGHTS hooke
  // (spring-dashpot tuned to e) both give e exactly in continuous time. Measured (docs/paper-reproduction.md,
  // "Time step"): the hysteretic law is within 0.6 % at a tenth of the critical step, the hooke
  // dashpot loses 13 % of e = 0.3 there and needs a fiftieth for 1.5 %.
  struct Case {
    study::NormalModel normal;
    double fraction, tolerance;
  };
  for (const Case c : {Case{study::NormalModel::EdemHysteretic, 0.1, 0.01}, Case{study::NormalModel::Hooke, 0.02, 0.02}}) {
    for (const double e : {0.3, 0.5, 0.8}) {
      SoilParameters p;
      p.restitution = e;
      p.model.normal = c.normal;
      p.model.damping_factor = 0;
      study::Study st;
      st.soil = makeSoil(p);
      st.dem.criterion = study::TimeStepCriterion::StiffestSpring;
      st.dem.dt_fraction = c.fraction;
      const double r = st.soil.diameter_min_m / 2, v0 = 0.1, gap = 1e-5;
      DemSimulation sim(st.soil, box(0.1), 1);
      sim.setGravity({0, 0, 0});
      sim.addParticle({{-r - gap, 0, 0}, {v0, 0, 0}, {0, 0, 0}, r, 0, 0});
      sim.addParticle({{r + gap, 0, 0}, {-v0, 0, 0}, {0, 0, 0}, r, 0, 0});
      const physics::DemStep step = physics::demTimeStep(st);
      sim.setTimeStep(step.step_s);
      // Until well after the contact: the approach gap / v0, then a few contact durations.
      sim.run(std::lround((gap / v0 + 20 * step.critical_s) / sim.timeStep()));
      REQUIRE(sim.particle(1).x[0] - sim.particle(0).x[0] > 2 * r);
      const double e_measured = (sim.particle(1).v[0] - sim.particle(0).v[0]) / (2 * v0);
      CHECK(e_measured == Approx(e).epsilon(c.tolerance));
    }
  }
}

TEST_CASE("sphere resting on a plane and on a mesh face has overlap m g / K1", "[builtin]") {
  SoilParameters p;
  p.restitution = 0.9;  // small unloading excursions shift the rest point least
  const double m = sphereMass(p.density, kR);
  const double k1 = 5 * kR * p.yield;  // wall contact: R* = R
  const double expected = m * kG / k1;
  SECTION("plane") {
    DemSimulation sim(makeSoil(p), box(0.1), 1);
    sim.addPlane({{0, 0, 0}, {0, 1, 0}, 1});
    sim.addParticle({{0, kR, 0}, {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    sim.setTimeStep(1e-5);
    // Tolerance 1e-3 (relative); the ramp spans about 300 contact periods.
    CHECK(quasiStaticRestingOverlap(sim, 0.4, 0.02) == Approx(expected).epsilon(1e-3));
  }
  SECTION("mesh face") {
    DemSimulation sim(makeSoil(p), box(0.1), 1);
    TriangleMesh mesh = flatMesh(0.02, 4);
    mesh.material = 1;
    sim.addMesh(mesh);
    sim.addParticle({{0.0021, kR, 0.0063}, {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    sim.setTimeStep(1e-5);
    CHECK(quasiStaticRestingOverlap(sim, 0.4, 0.02) == Approx(expected).epsilon(1e-3));
  }
}

TEST_CASE("LIGGGHTS hooke: resting overlap is m g / kn with kn from Y*, R*, m* and v_char", "[builtin]") {
  SoilParameters p;
  p.model.normal = study::NormalModel::Hooke;
  p.model.cohesion = study::CohesionModel::None;
  p.model.rolling = study::RollingModel::Cdt;
  const auto soil = makeSoil(p);
  DemSimulation sim(soil, box(0.1), 1);
  sim.addPlane({{0, 0, 0}, {0, 1, 0}, 1});
  sim.addParticle({{0, kR, 0}, {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
  sim.setTimeStep(1e-6);
  sim.run(100000);  // 0.1 s: damped (e = 0.5) settling
  const double m = sphereMass(p.density, kR);
  const auto& g = soil.materials[0];
  const auto& w = soil.materials[1];
  const double yeff = 1 / ((1 - g.poisson * g.poisson) / g.youngs_Pa + (1 - w.poisson * w.poisson) / w.youngs_Pa);
  const double v = p.model.characteristic_velocity_m_s;
  // LIGGGHTS 3.8 normal_model_hooke.h with R* = R, m* = m against a wall.
  const double kn = 16.0 / 15.0 * std::sqrt(kR) * yeff * std::pow(15 * m * v * v / (16 * std::sqrt(kR) * yeff), 0.2);
  CHECK(kR - sim.particle(0).x[1] == Approx(m * kG / kn).epsilon(1e-6));
}

TEST_CASE("a sliding sphere ends rolling at 5/7 of its initial speed", "[builtin]") {
  SoilParameters p;
  p.friction = 0.3;
  const double m = sphereMass(p.density, kR);
  DemSimulation sim(makeSoil(p), box(0.5), 1);
  sim.addPlane({{0, 0, 0}, {0, 1, 0}, 1});
  const double v0 = 0.5;
  sim.addParticle({{0, kR - m * kG / (5 * kR * p.yield), 0}, {v0, 0, 0}, {0, 0, 0}, kR, 0, 0});
  sim.setTimeStep(1e-5);
  sim.run(15000);  // 0.15 s; rolling starts at 2 v0 / (7 mu g) = 0.049 s
  const auto s = sim.particle(0);
  // Tolerance 0.2 % of v0: the tangential spring's stick transition leaves a damped ripple.
  CHECK(s.v[0] == Approx(5.0 / 7.0 * v0).margin(2e-3 * v0));
  CHECK(-s.w[2] * kR == Approx(s.v[0]).epsilon(1e-2));  // rolls without slip: v = -w_z R
}

TEST_CASE("rolling friction decelerates a rolling sphere at (5/7) mu_r g", "[builtin]") {
  for (const auto rolling : {study::RollingModel::EdemStandard, study::RollingModel::Cdt}) {
    DemSimulation sim = rollingSphere(rolling);
    sim.run(2000);
    // Least-squares slope of v(t) over 0.02 .. 0.2 s (the sphere stops at about 0.29 s).
    double st = 0, sv = 0, stt = 0, stv = 0;
    int n = 0;
    for (int s = 0; s < 180; ++s) {
      sim.run(100);
      const double t = sim.time(), v = sim.particle(0).v[0];
      st += t, sv += v, stt += t * t, stv += t * v;
      ++n;
    }
    const double slope = (n * stv - st * sv) / (n * stt - st * st);
    // Tolerance: 1 %.
    CHECK(-slope == Approx(5.0 / 7.0 * kRollingFriction * kG).epsilon(1e-2));
  }
}

TEST_CASE("edem-standard rolling friction stops a rolling sphere at v0^2 / (10/7 mu_r g) and leaves it at rest", "[builtin]") {
  // The law as stated (a constant torque -mu_r Fn R w_hat) reverses the spin every step once the
  // sphere has stopped: |w| chatters at about mu_r m g R dt / I = 4.9e-3 rad/s here, for ever.
  DemSimulation sim = rollingSphere(study::RollingModel::EdemStandard);
  sim.run(50000);  // 0.5 s; it stops at about 0.29 s
  const auto s = sim.particle(0);
  // Stopping distance under the constant deceleration (5/7) mu_r g: 1 %.
  CHECK(s.x[0] == Approx(kRollingV0 * kRollingV0 / (10.0 / 7.0 * kRollingFriction * kG)).epsilon(1e-2));
  // At rest: no chatter left (the regularised law's spin decays by 1/12 per step below its scale).
  CHECK(std::sqrt(s.w[0] * s.w[0] + s.w[1] * s.w[1] + s.w[2] * s.w[2]) < 1e-9);
  CHECK(std::fabs(s.v[0]) < 1e-9);
}

TEST_CASE("below the regularisation step, edem-standard spin decays as exp(-t / (12 dt_r)) at any DEM step", "[builtin]") {
  // A sphere resting on the plane, spinning about the normal below the law's spin scale: the torque
  // -mu_r Fn R w / w0 with w0 = 12 mu_r Fn R dt_r / I is -I w / (12 dt_r), whatever Fn, and the
  // spin about the normal moves no contact point, so w decays as exp(-t / (12 dt_r)).
  constexpr double kRegularisation = 1e-4, kSpin = 0.1;  // s; rad/s, under w0 = 30 mu_r g dt_r / R = 0.59
  const auto spinAfter = [](double dt, double regularisation, double t) {
    SoilParameters p;
    p.rolling_friction = kRollingFriction;
    p.model.rolling = study::RollingModel::EdemStandard;
    const double m = sphereMass(p.density, kR);
    DemSimulation sim(makeSoil(p), box(0.5), 1);
    sim.addPlane({{0, 0, 0}, {0, 1, 0}, 1});
    sim.addParticle({{0, kR - m * kG / (5 * kR * p.yield), 0}, {0, 0, 0}, {0, kSpin, 0}, kR, 0, 0});
    sim.setTimeStep(dt);
    sim.setRollingRegularisationStep(regularisation);
    sim.run(std::lround(t / dt));
    return sim.particle(0).w[1];
  };
  const double t = 12 * kRegularisation;
  const double coarse = spinAfter(2.5e-5, kRegularisation, t), fine = spinAfter(1e-5, kRegularisation, t);
  // Tolerance 1.5 %: explicit Euler's (1 - dt / (12 dt_r))^n is 1.0 % (dt 2.5e-5) and 0.4 % (1e-5) below.
  CHECK(coarse == Approx(kSpin * std::exp(-1.0)).epsilon(0.015));
  CHECK(fine == Approx(kSpin * std::exp(-1.0)).epsilon(0.015));
  // Without a regularisation step the scale follows the DEM step: the spin decays 12 dt_r / (12 dt)
  // times faster, the dependence on the step the regularisation step removes.
  CHECK(spinAfter(1e-5, 0, t) < 1e-3 * fine);
}

TEST_CASE("cohesive pair needs k_coh pi R* delta0 to separate after loading to delta_max", "[builtin]") {
  // EDEM hysteretic + linear cohesion: on unloading Fn = K2 (delta - delta0) - k pi R* delta, so the
  // largest tension along the separation path is at delta0 = delta_max (1 - e^2): k pi R* delta0.
  study::ContactModel model;
  PairLaw law;
  law.restitution = 0.5;
  law.cohesion_J_m3 = 2e5;
  law.yield_min_Pa = 1e6;
  law.friction = 0.5;
  const double reff = kR / 2, meff = sphereMass(2000, kR) / 2;
  const ContactStiffness s = contactStiffness(model, law, reff, meff);
  ContactHistory hist;
  ContactKinematics k{};
  k.n[0] = 1;
  k.reff = reff;
  k.ri = k.rj = kR;
  k.di = k.dj = kR;
  const double delta_max = 2e-4;
  double max_tension = 0;
  for (int step = 1; step < 4000; ++step) {  // load 0 -> delta_max, then unload to 0
    k.delta = step <= 2000 ? delta_max * step / 2000 : delta_max * (4000 - step) / 2000;
    k.r = 2 * kR - k.delta;
    const auto res = contactForce<study::NormalModel::EdemHysteretic, study::RollingModel::None, true>(
        model, law, s, k, 1e-6, 1e-6, cohesionForce(model.cohesion, law, k, false), hist, false);
    max_tension = std::max(max_tension, -res.normal_force);
  }
  const double delta0 = delta_max * (1 - law.restitution * law.restitution);
  // Sampling of the path at 1e-7 m steps: within 0.1 %.
  CHECK(max_tension == Approx(law.cohesion_J_m3 * std::numbers::pi * reff * delta0).epsilon(1e-3));
}

TEST_CASE("face, edge and vertex hits of a mesh give the plane's force once; node forces keep force and moment",
          "[builtin]") {
  SoilParameters p;
  p.model.damping_factor = 0;  // force magnitude K1 delta without the viscous term of the rebound
  const double delta = 2e-5;
  struct Hit {
    const char* where;
    double x, z;
  };
  // flatMesh(0.02, 4): nodes every 10 mm; diagonals from (i,k) to (i+1,k+1).
  for (const Hit hit : {Hit{"face", 0.0031, 0.0072}, Hit{"edge (grid line)", 0.0043, 0.0}, Hit{"edge (diagonal)", 0.004, 0.004},
                        Hit{"vertex (6 triangles)", 0.0, 0.0}, Hit{"boundary vertex (3 triangles)", 0.01, -0.02}}) {
    INFO(hit.where);
    DemSimulation with_plane(makeSoil(p), box(0.1), 1);
    with_plane.setGravity({0, 0, 0});
    with_plane.addPlane({{0, 0, 0}, {0, 1, 0}, 1});
    with_plane.addParticle({{hit.x, kR - delta, hit.z}, {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    with_plane.setTimeStep(1e-6);
    DemSimulation with_mesh(makeSoil(p), box(0.1), 1);
    with_mesh.setGravity({0, 0, 0});
    TriangleMesh mesh = flatMesh(0.02, 4);
    mesh.material = 1;
    with_mesh.addMesh(mesh);
    with_mesh.addParticle({{hit.x, kR - delta, hit.z}, {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    with_mesh.setTimeStep(1e-6);
    with_plane.run(5);
    with_mesh.run(5);
    const Vec3 fp = with_plane.planeForce(0);
    const auto& nf = with_mesh.nodeForces(0);
    Vec3 total{0, 0, 0}, moment{0, 0, 0};
    const auto& nodes = with_mesh.mesh(0).nodes;
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const double* f = &nf[3 * k];
      for (int c = 0; c < 3; ++c) total[c] += f[c];
      moment[0] += nodes[k][1] * f[2] - nodes[k][2] * f[1];
      moment[1] += nodes[k][2] * f[0] - nodes[k][0] * f[2];
      moment[2] += nodes[k][0] * f[1] - nodes[k][1] * f[0];
    }
    // Same force as the plane (round-off of the barycentric split only), K1 delta in size.
    CHECK(fp[1] == Approx(-5 * kR * p.yield * delta).epsilon(1e-2));
    CHECK(total[1] == Approx(fp[1]).epsilon(1e-10));
    CHECK(std::fabs(total[0]) < 1e-12);
    CHECK(std::fabs(total[2]) < 1e-12);
    // Moment about the origin of a force at the contact point (x, 0, z): (-z Fy, 0, x Fy).
    const auto s = with_mesh.particle(0);
    CHECK(moment[0] == Approx(-s.x[2] * total[1]).margin(1e-12));
    CHECK(moment[2] == Approx(s.x[0] * total[1]).margin(1e-12));
    CHECK(with_mesh.contactCount() == 1);
  }
}

TEST_CASE("a step above the stiffest spring's stability limit is refused", "[builtin]") {
  SoilParameters p;
  DemSimulation sim(makeSoil(p), box(0.1), 1);
  sim.addParticle({{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
  const double m = sphereMass(p.density, kR);
  // Stiffest spring: wall K2 = 5 R Y / e^2 with m* = m.
  const double limit = 2 * std::sqrt(m / (5 * kR * p.yield / (p.restitution * p.restitution)));
  CHECK(sim.stabilityLimit() == Approx(limit).epsilon(1e-12));
  CHECK_THROWS_WITH(sim.setTimeStep(1.01 * limit), Catch::Contains("stability limit"));
  CHECK_NOTHROW(sim.setTimeStep(0.2 * limit));
}

// Within one run a step's last phase also drifts the particles for the next step; the failure's
// message (its step, and the position and velocity of the particle) is that of steps run one by one.
TEST_CASE("a blow-up names the particle and the step", "[builtin]") {
  const auto message = [](int threads, long steps_per_run) {
    SoilParameters p;
    DemSimulation sim(makeSoil(p), box(0.1), threads);
    sim.addParticle({{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    sim.addParticle({{0.0201, 0.0, 0.0}, {50, 0, 0}, {0, 0, 0}, kR, 0, 0});  // leaves x <= 0.1 m after 1.6 ms
    sim.setTimeStep(1e-5);
    try {
      for (long done = 0; done < 1000; done += steps_per_run) sim.run(steps_per_run);
    } catch (const BlowUp& e) {
      return std::string(e.what());
    }
    return std::string("no blow-up");
  };
  for (const int threads : {1, 2}) {
    INFO("threads " << threads);
    const std::string in_one_run = message(threads, 1000);
    CHECK_THAT(in_one_run, Catch::Contains("blew up") && Catch::Contains("particle 1 ") && Catch::Contains("step 160 ") &&
                               Catch::Contains("left the domain"));
    CHECK(in_one_run == message(threads, 1));
  }
}

// A small sphere shot into a large one fails in the step its overlap first passes half the smaller
// radius (not the larger), named by the pair's lower index; the pair sits past 400 spheres without
// contacts, so it lies in a later batch of rows and, with 2 threads, in the second part.
TEST_CASE("a pair overlap beyond half the smaller radius names the lower particle in the step it happens", "[builtin]") {
  for (int threads : {1, 2}) {
    SoilParameters p;
    DemSimulation sim(makeSoil(p), box(0.1), threads);
    sim.setGravity({0, 0, 0});
    for (int k = 0; k < 400; ++k)  // 3 kR apart: a gap of kR, beyond the list's reach
      sim.addParticle({{-0.075 + 0.015 * (k % 10), -0.075 + 0.015 * (k / 10 % 10), -0.06 + 0.015 * (k / 100)},
                       {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    const double small = 0.5 * kR, speed = 20, dt = 1e-6;
    sim.addParticle({{0, 0.08, 0}, {0, 0, 0}, {0, 0, 0}, kR, 0, 0});
    sim.addParticle({{kR + small + 0.1e-3, 0.08, 0}, {-speed, 0, 0}, {0, 0, 0}, small, 0, 0});
    sim.setTimeStep(dt);
    double last_overlap = 0;
    bool failed = false;
    for (int step = 0; step < 1000 && !failed; ++step) {
      try {
        sim.run(1);
        last_overlap = sim.maxOverlap();
      } catch (const BlowUp& e) {
        failed = true;
        CHECK_THAT(e.what(), Catch::Contains("particle 400 ") && Catch::Contains("overlap with a neighbour exceeds"));
      }
    }
    INFO(threads << " thread(s)");
    REQUIRE(failed);
    // The step before held an overlap within the limit and at most one step's approach short of it.
    CHECK(last_overlap <= 0.5 * small);
    CHECK(last_overlap > 0.5 * small - speed * dt);
  }
}

// A particle driven into a tool surface beyond the overlap limit is reported against that surface,
// with the two steps that can be too long (the coupling step on a deforming tool: docs/builtin-dem.md).
TEST_CASE("a wall overlap blow-up names the tool surface and the coupling step", "[builtin]") {
  SoilParameters p;
  DemSimulation sim(makeSoil(p), box(0.1), 1);
  TriangleMesh mesh = flatMesh(0.02, 4);
  mesh.name = "PMMA";
  mesh.material = 1;
  sim.addMesh(mesh);
  // 50 m/s into the face: far more than the wall spring stops within the overlap limit.
  sim.addParticle({{0.0021, 1.05 * kR, 0.0063}, {0, -50, 0}, {0, 0, 0}, kR, 0, 0});
  sim.setTimeStep(1e-6);
  CHECK_THROWS_WITH(sim.run(2000), Catch::Contains("blew up") && Catch::Contains("particle 0 ") && Catch::Contains("the surface of 'PMMA'") &&
                                        Catch::Contains("fem.dt_s"));
}
