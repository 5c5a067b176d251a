// Many-particle checks of the builtin DEM: conservation, determinism, checkpoint/restore, speed.
#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/backends/builtin/vector_isa.hpp"
#include "test_soil.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

using namespace demfem;
using namespace demfem::builtin;
using namespace demfem::builtin::testing;

namespace {

// A cloud of `n` spheres (radius 4.75-5.25 mm) on a jittered lattice in a cube of edge 0.1 m,
// random velocities up to 0.5 m/s: collisions start at once.
void addCloud(DemSimulation& sim, int per_edge, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double spacing = 0.0105;
  for (int k = 0; k < per_edge; ++k)
    for (int j = 0; j < per_edge; ++j)
      for (int i = 0; i < per_edge; ++i) {
        ParticleState p;
        p.radius = 0.005 + 0.00025 * u(rng);
        p.x = {spacing * (i - per_edge / 2.0) + 1e-4 * u(rng), spacing * (j - per_edge / 2.0) + 1e-4 * u(rng),
               spacing * (k - per_edge / 2.0) + 1e-4 * u(rng)};
        p.v = {0.5 * u(rng), 0.5 * u(rng), 0.5 * u(rng)};
        p.w = {20 * u(rng), 20 * u(rng), 20 * u(rng)};
        sim.addParticle(p);
      }
}

SoilParameters cohesiveRolling() {
  SoilParameters p;
  p.cohesion = 5e4;
  p.rolling_friction = 0.1;
  return p;
}

std::vector<double> positions(const DemSimulation& sim) {
  std::vector<double> x;
  for (std::size_t i = 0; i < sim.particleCount(); ++i) {
    const auto s = sim.particle(i);
    x.insert(x.end(), {s.x[0], s.x[1], s.x[2], s.v[0], s.v[1], s.v[2], s.w[0], s.w[1], s.w[2]});
  }
  return x;
}

// A settling box: floor and four walls as planes, gravity.
DemSimulation settlingBox(int threads, const SoilParameters& p) {
  DemSimulation sim(makeSoil(p), box(0.2), threads);
  sim.addPlane({{0, -0.06, 0}, {0, 1, 0}, 1});
  sim.addPlane({{-0.06, 0, 0}, {1, 0, 0}, 1});
  sim.addPlane({{0.06, 0, 0}, {-1, 0, 0}, 1});
  sim.addPlane({{0, 0, -0.06}, {0, 0, 1}, 1});
  sim.addPlane({{0, 0, 0.06}, {0, 0, -1}, 1});
  addCloud(sim, 8, 42);
  sim.setTimeStep(2e-5);
  return sim;
}

}  // namespace

TEST_CASE("total momentum of a closed granular system is conserved to round-off", "[builtin]") {
  for (const auto normal : {study::NormalModel::EdemHysteretic, study::NormalModel::HookeHysteresis}) {
    SoilParameters p = cohesiveRolling();
    p.model.normal = normal;
    p.model.rolling = normal == study::NormalModel::EdemHysteretic ? study::RollingModel::EdemStandard
                                                                   : study::RollingModel::Epsd;
    p.model.cohesion = normal == study::NormalModel::EdemHysteretic ? study::CohesionModel::EdemLinear
                                                                    : study::CohesionModel::Sjkr;
    DemSimulation sim(makeSoil(p), box(1.0), 1);
    sim.setGravity({0, 0, 0});
    addCloud(sim, 6, 7);
    sim.setTimeStep(2e-5);
    const Vec3 p0 = sim.momentum();
    double scale = 0;
    for (std::size_t i = 0; i < sim.particleCount(); ++i) {
      const auto s = sim.particle(i);
      scale += sphereMass(p.density, s.radius) * std::sqrt(s.v[0] * s.v[0] + s.v[1] * s.v[1] + s.v[2] * s.v[2]);
    }
    sim.run(2000);
    REQUIRE(sim.contactCount() > 0);
    const Vec3 p1 = sim.momentum();
    // Pair forces are applied as +f / -f: only summation round-off remains (1e-13 of sum m |v|).
    for (int c = 0; c < 3; ++c) CHECK(std::fabs(p1[c] - p0[c]) < 1e-13 * scale);
  }
}

TEST_CASE("two runs with the same inputs and thread count are bit-identical", "[builtin]") {
  for (const int threads : {1, 2}) {
    INFO("threads " << threads);
    DemSimulation a = settlingBox(threads, cohesiveRolling());
    DemSimulation b = settlingBox(threads, cohesiveRolling());
    a.run(600);
    b.run(600);
    const auto xa = positions(a), xb = positions(b);
    REQUIRE(xa.size() == xb.size());
    CHECK(std::memcmp(xa.data(), xb.data(), xa.size() * sizeof(double)) == 0);
  }
}

// Within one run a step's last phase also does the next step's drift (docs/builtin-dem.md,
// "Threads on a shared machine"); steps run one at a time do not. Both must give the same bits,
// through list rebuilds and wall contacts.
TEST_CASE("one run of many steps moves the particles as many runs of one step do, bit for bit", "[builtin]") {
  for (const int threads : {1, 2}) {
    INFO("threads " << threads);
    DemSimulation whole = settlingBox(threads, cohesiveRolling());
    DemSimulation single = settlingBox(threads, cohesiveRolling());
    whole.run(300);
    for (int s = 0; s < 300; ++s) single.run(1);
    REQUIRE(whole.contactCount() > 0);
    CHECK(whole.stepCount() == single.stepCount());
    const auto xw = positions(whole), xs = positions(single);
    REQUIRE(xw.size() == xs.size());
    CHECK(std::memcmp(xw.data(), xs.data(), xw.size() * sizeof(double)) == 0);
  }
}

// The pair and wall loops' batch loops and the Verlet sweeps are compiled for each instruction set
// (docs/builtin-dem.md, "Performance design"): each must give the baseline's bits, on pair
// contacts, on the box's planes and on a mesh moving into the cloud (its contacts take the mesh's
// velocity), with settling damping and without.
TEST_CASE("every vector instruction set of the contact loops and the Verlet sweeps moves the particles to the same bits",
          "[builtin]") {
  // The three model sets the backend ships (docs/builtin-dem.md), each with its cohesion and rolling.
  SoilParameters edem = cohesiveRolling();
  SoilParameters luding = cohesiveRolling();
  luding.model.normal = study::NormalModel::HookeHysteresis;
  luding.model.cohesion = study::CohesionModel::Sjkr;
  luding.model.rolling = study::RollingModel::Epsd;
  SoilParameters hooke = cohesiveRolling();
  hooke.cohesion = 0;
  hooke.model.normal = study::NormalModel::Hooke;
  hooke.model.cohesion = study::CohesionModel::None;
  hooke.model.rolling = study::RollingModel::Cdt;
  struct Uncap {
    ~Uncap() { capVectorIsa(VectorIsa::Avx512); }
  } uncap;
  for (const SoilParameters& p : {edem, luding, hooke}) {
    std::vector<double> baseline;
    for (const VectorIsa isa : {VectorIsa::Baseline, VectorIsa::Avx2, VectorIsa::Avx512}) {
      if (isa > hostVectorIsa()) continue;
      INFO("normal model " << static_cast<int>(p.model.normal) << ", " << vectorIsaName(isa));
      capVectorIsa(isa);
      REQUIRE(vectorIsa() == isa);
      DemSimulation sim = settlingBox(1, p);
      TriangleMesh plate = flatMesh(0.03, 3);
      plate.material = 1;
      sim.setMeshMotion(sim.addMesh(plate), {0, -0.05, 0}, {0.1, 0.5, 0}, 0);  // rising under the cloud
      // Wall contacts were there: the side walls carried load at some time, the plate at the end.
      bool loaded[5] = {false, false, false, false, false};
      sim.setSettlingDamping(20);
      for (int chunk = 0; chunk < 30; ++chunk) {
        if (chunk == 15) sim.setSettlingDamping(0);
        sim.run(100);
        for (int plane = 0; plane < 5; ++plane) loaded[plane] = loaded[plane] || sim.planeForce(plane) != Vec3{0, 0, 0};
      }
      REQUIRE(sim.contactCount() > 10);
      REQUIRE(std::count(loaded + 1, loaded + 5, true) >= 2);
      const auto& node_force = sim.nodeForces(0);
      REQUIRE(std::any_of(node_force.begin(), node_force.end(), [](double f) { return f != 0; }));
      auto x = positions(sim);
      x.insert(x.end(), node_force.begin(), node_force.end());
      if (baseline.empty()) baseline = x;
      REQUIRE(x.size() == baseline.size());
      CHECK(std::memcmp(x.data(), baseline.data(), x.size() * sizeof(double)) == 0);
    }
  }
}

TEST_CASE("a restored checkpoint continues bit-identically", "[builtin]") {
  for (const int threads : {1, 2}) {
    INFO("threads " << threads);
    DemSimulation a = settlingBox(threads, cohesiveRolling());
    a.run(700);
    adapter::PayloadWriter state;
    a.saveState(state);
    a.run(700);
    DemSimulation b = settlingBox(threads, cohesiveRolling());
    adapter::PayloadReader in(state.bytes(), "state");
    b.loadState(in);
    b.run(700);
    CHECK(a.stepCount() == b.stepCount());
    const auto xa = positions(a), xb = positions(b);
    CHECK(std::memcmp(xa.data(), xb.data(), xa.size() * sizeof(double)) == 0);
  }
}

TEST_CASE("2 and 3 threads move the particles as 1 thread does, to summation round-off", "[builtin]") {
  // Only the order of the pair-force sums differs between thread counts: after 50 steps of a
  // settling cloud positions, velocities and spins agree to 1e-9 (SI); a lost or doubled contact
  // force would change a velocity by about its acceleration times 50 dt, g 50 dt = 1e-2 m/s or more.
  DemSimulation one = settlingBox(1, cohesiveRolling());
  one.run(50);
  REQUIRE(one.contactCount() > 0);
  for (const int threads : {2, 3}) {
    INFO("threads " << threads);
    DemSimulation many = settlingBox(threads, cohesiveRolling());
    many.run(50);
    CHECK(many.contactCount() == one.contactCount());
    const auto x1 = positions(one), xn = positions(many);
    REQUIRE(x1.size() == xn.size());
    double worst = 0;
    for (std::size_t k = 0; k < x1.size(); ++k) worst = std::max(worst, std::fabs(x1[k] - xn[k]));
    CHECK(worst < 1e-9);
  }
}

TEST_CASE("every part carries its wall contacts' history from step to step and through a checkpoint", "[builtin]") {
  // Spheres far apart sliding on a floor: no pair forces, so no sum whose order depends on the
  // thread count, and 2 or 3 threads must give 1 thread's bits. Each part keeps its own wall
  // contacts; one that lost their tangential history would slide its spheres otherwise.
  const auto sliding = [](int threads) {
    DemSimulation sim(makeSoil(cohesiveRolling()), box(0.5), threads);
    sim.addPlane({{0, -0.06, 0}, {0, 1, 0}, 1});
    for (int k = 0; k < 9; ++k) {
      ParticleState p;
      p.radius = 0.005;
      p.x = {-0.2 + 0.04 * k, -0.06 + 0.005 - 1e-6, 0};  // about the resting overlap m g / K1
      p.v = {0.1 + 0.02 * k, 0, 0.05};
      sim.addParticle(p);
    }
    sim.setTimeStep(2e-5);
    return sim;
  };
  DemSimulation one = sliding(1);
  one.run(1000);
  REQUIRE(one.contactCount() == 9);
  for (std::size_t k = 0; k < one.particleCount(); ++k) {
    const auto s = one.particle(k);
    CHECK(s.v[0] < 0.1 + 0.02 * static_cast<double>(k));  // friction slowed it down...
    CHECK(std::fabs(s.w[2]) > 1.0);                        // ...and set it rolling
  }
  for (const int threads : {2, 3}) {
    INFO("threads " << threads);
    DemSimulation many = sliding(threads);
    many.run(400);
    adapter::PayloadWriter state;
    many.saveState(state);
    DemSimulation resumed = sliding(threads);
    adapter::PayloadReader in(state.bytes(), "state");
    resumed.loadState(in);
    many.run(600);
    resumed.run(600);
    const auto x1 = positions(one), xn = positions(many), xr = positions(resumed);
    REQUIRE(xn.size() == x1.size());
    CHECK(std::memcmp(xn.data(), x1.data(), x1.size() * sizeof(double)) == 0);
    CHECK(std::memcmp(xr.data(), x1.data(), x1.size() * sizeof(double)) == 0);
  }
}

TEST_CASE("a checkpoint of another thread count is refused with a message", "[builtin]") {
  DemSimulation a = settlingBox(2, cohesiveRolling());
  a.run(10);
  adapter::PayloadWriter state;
  a.saveState(state);
  DemSimulation b = settlingBox(1, cohesiveRolling());
  adapter::PayloadReader in(state.bytes(), "state");
  CHECK_THROWS_WITH(b.loadState(in), Catch::Contains("threads"));
}

TEST_CASE("a checkpoint whose part window disagrees with its neighbour rows is refused", "[builtin]") {
  // A window end below its part's rows let a part write forces another part owns (found by the
  // checkpoint fuzzer as a failed assertion in the pair-force loop).
  DemSimulation a = settlingBox(2, cohesiveRolling());
  a.run(10);
  adapter::PayloadWriter state;
  a.saveState(state);
  std::string bytes = state.bytes();
  // The windows are stored as a count of 2 followed by two ends, the last being the particle count.
  const std::uint64_t n = a.particleCount();
  std::vector<std::size_t> at;
  for (std::size_t k = 0; k + 24 <= bytes.size(); ++k) {
    std::uint64_t w[3];
    std::memcpy(w, bytes.data() + k, sizeof w);
    if (w[0] == 2 && w[1] >= n / 2 && w[1] <= n && w[2] == n) at.push_back(k);
  }
  REQUIRE(at.size() == 1);
  const std::uint64_t too_short = n / 2 - 1;
  std::memcpy(bytes.data() + at.front() + 8, &too_short, sizeof too_short);
  DemSimulation b = settlingBox(2, cohesiveRolling());
  adapter::PayloadReader in(bytes, "state");
  CHECK_THROWS_WITH(b.loadState(in), Catch::Contains("part window"));
}
