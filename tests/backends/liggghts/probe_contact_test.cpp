// A fixed probe sphere pressed on the tool mesh: the force LIGGGHTS reports must be the hooke contact
// law evaluated on the geometry we set (bent by setNodePositions, normals updated from the first step),
// split to keypoints so that their sum is the stress mesh's total force.
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/backends/liggghts/input_deck.hpp"
#include "small_study.hpp"
#include "support/study_in_code.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <numbers>
#include <optional>

using namespace demfem;
using liggghts::testing::smallStudy;
using Vec3 = std::array<double, 3>;

namespace {

constexpr double kRadius = 0.005;
constexpr double kOverlap = 0.0005;

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// Backend options with one fixed probe sphere of the soil material, kRadius, centred at `centre` (bin frame).
liggghts::BackendOptions probeAt(const Vec3& centre) {
  liggghts::ProbeSphere p;
  p.centre_m = centre;
  p.radius_m = kRadius;
  p.material = "soil";
  liggghts::BackendOptions options;
  options.probes = {p};
  return options;
}

struct Setup {
  study::Study study = smallStudy();
  Vec3 centre_local{};  // probe centre in the tool's local frame
  Vec3 origin{};        // tool origin in the bin
  Setup() {
    study.tools[0].motion.start_z_m = 0.08;  // inside the bin, away from its end walls
    origin = liggghts::toolStartOrigin(study, 0);
    centre_local = {0.0033, 0.0533, study.tools[0].geometry.thickness_m / 2 + kRadius - kOverlap};
  }
  liggghts::BackendOptions probe() const {
    return probeAt({origin[0] + centre_local[0], origin[1] + centre_local[1], origin[2] + centre_local[2]});
  }
  double mass() const { return 2600 * 4.0 / 3.0 * std::numbers::pi * std::pow(kRadius, 3); }
  // LIGGGHTS 3.8 hooke (normal_model_hooke.h), sphere on a wall: R* = R, m* = m, Y* from both materials.
  double kn() const {
    const double y_eff = 1 / ((1 - 0.09) / 5e6 + (1 - 0.09) / 2e8);
    const double v = study.soil.contact.characteristic_velocity_m_s;
    return 16.0 / 15.0 * std::sqrt(kRadius) * y_eff *
           std::pow(15.0 * mass() * v * v / (16.0 * std::sqrt(kRadius) * y_eff), 0.2);
  }
};

Vec3 sum(const adapter::NodeArray& f) {
  Vec3 s{};
  for (std::size_t k = 0; k < f.size() / 3; ++k)
    for (std::size_t c = 0; c < 3; ++c) s[c] += f[3 * k + c];
  return s;
}

}  // namespace

TEST_CASE("a probe on the bent tool gets the hooke force of the bent geometry from the first step", "[liggghts]") {
  Setup setup;
  auto backend = liggghts::makeBackend(setup.study, setup.probe());
  const auto geometry = backend->geometries().at(0);
  const double dt = backend->info().dem_time_step_s;
  backend->simulate(dt);  // LIGGGHTS is set up with the flat plate: the bend below comes after it
  auto xyz = backend->nodePositions("tool");
  REQUIRE(xyz.size() == 3 * static_cast<std::size_t>(geometry.node_count));

  // Bend the plate about the probe: dz = a (y - y0) + b (y - y0)^2, both faces alike.
  const double a = 0.2, b = 2.0, y0 = setup.centre_local[1];
  auto bent = xyz;
  for (std::size_t k = 0; k < bent.size() / 3; ++k) {
    const double y = bent[3 * k + 1] - y0;
    bent[3 * k + 2] += a * y + b * y * y;
  }
  backend->setNodePositions("tool", bent);
  backend->simulate(dt);  // exactly one DEM step

  // Positions read back from LIGGGHTS' mesh are the ones we set.
  const auto read_back = backend->nodePositions("tool");
  for (std::size_t v = 0; v < bent.size(); ++v) REQUIRE(read_back[v] == Approx(bent[v]).margin(1e-12));

  // Reference: the front-face triangle the probe centre projects into, its plane and outward normal.
  std::optional<Vec3> expected;
  for (const auto& tri : geometry.triangles) {
    Vec3 p[3];
    for (int j = 0; j < 3; ++j)
      for (int c = 0; c < 3; ++c) p[j][c] = bent[3 * static_cast<std::size_t>(tri[j]) + c];
    Vec3 n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
    const double len = std::sqrt(dot(n, n));
    for (double& v : n) v /= len;
    if (n[2] < 0.5) continue;  // front face only
    const double distance = dot(n, sub(setup.centre_local, p[0]));
    const Vec3 q{setup.centre_local[0] - distance * n[0], setup.centre_local[1] - distance * n[1],
                 setup.centre_local[2] - distance * n[2]};
    bool inside = true;
    for (int j = 0; j < 3; ++j) inside = inside && dot(cross(sub(p[(j + 1) % 3], p[j]), sub(q, p[j])), n) > 0;
    if (!inside) continue;
    const double overlap = kRadius - distance;
    REQUIRE(overlap > 0);
    // Force on the mesh: the probe is pushed out along n, the mesh in along -n (no motion: no damping).
    expected = Vec3{-setup.kn() * overlap * n[0], -setup.kn() * overlap * n[1], -setup.kn() * overlap * n[2]};
  }
  REQUIRE(expected);
  REQUIRE(std::abs((*expected)[1]) > 0.05 * std::abs((*expected)[2]));  // the bend tilts the normal

  const Vec3 total = sum(backend->nodeForces("tool", adapter::ForceMode::Instantaneous));
  const Vec3 mesh_total = liggghts::meshTotalForce(*backend, "tool");
  for (std::size_t c = 0; c < 3; ++c) {
    // Closed-form contact law on the bent plane: LIGGGHTS computes it in double precision.
    CHECK(total[c] == Approx((*expected)[c]).epsilon(1e-6).margin(1e-9));
    // Keypoint split conserves the force LIGGGHTS' stress mesh sums up.
    CHECK(total[c] == Approx(mesh_total[c]).epsilon(1e-9).margin(1e-12));
  }
}

TEST_CASE("interval-mean node forces are the mean over every step, not the last step", "[liggghts]") {
  Setup setup;
  auto backend = liggghts::makeBackend(setup.study, setup.probe());
  const double dt = backend->info().dem_time_step_s;
  // Drive the tool towards the probe at v without a jump: origin(t) continues where it is.
  const double v = 0.01, t = backend->time();
  auto motion = backend->rigidMotion("tool");
  motion.origin_m = {motion.origin_m[0], motion.origin_m[1], motion.origin_m[2] + motion.velocity_m_s[2] * (t - motion.t0_s)};
  motion.velocity_m_s = {0, 0, v};
  motion.t0_s = t;
  backend->setRigidMotion("tool", motion);
  const int steps = 200;
  backend->simulate(steps * dt);
  CHECK(backend->time() == Approx(t + steps * dt).epsilon(1e-12));

  // hooke with viscous damping: F_k = kn (delta0 + v k dt) + gamma_n v, gamma_n = sqrt(4 m kn / (1 + (pi/ln e)^2))
  const double e = 0.5, kn = setup.kn();
  const double gamma_n = std::sqrt(4 * setup.mass() * kn / (1 + std::pow(std::numbers::pi / std::log(e), 2)));
  const double mean = kn * (kOverlap + v * dt * (steps + 1) / 2.0) + gamma_n * v;
  const double last = kn * (kOverlap + v * dt * steps) + gamma_n * v;
  const Vec3 mean_total = sum(backend->nodeForces("tool", adapter::ForceMode::IntervalMean));
  const Vec3 last_total = sum(backend->nodeForces("tool", adapter::ForceMode::Instantaneous));
  CHECK(mean_total[2] == Approx(-mean).epsilon(1e-6));  // the probe pushes the front face back (-z)
  CHECK(last_total[2] == Approx(-last).epsilon(1e-6));
  CHECK(std::abs(mean_total[0]) < 1e-9 * mean);
  CHECK(liggghts::meshTotalForce(*backend, "tool")[2] == Approx(last_total[2]).epsilon(1e-9));

  // Barycentric split keeps the moment: sum of r_k x f_k equals r_contact x F (contact point on the face).
  const auto xyz = backend->nodePositions("tool");
  const auto f = backend->nodeForces("tool", adapter::ForceMode::Instantaneous);
  Vec3 moment{};
  for (std::size_t k = 0; k < f.size() / 3; ++k) {
    const Vec3 m = cross({xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]}, {f[3 * k], f[3 * k + 1], f[3 * k + 2]});
    for (std::size_t c = 0; c < 3; ++c) moment[c] += m[c];
  }
  const Vec3 contact{setup.centre_local[0], setup.centre_local[1], setup.study.tools[0].geometry.thickness_m / 2};
  const Vec3 expected_moment = cross(contact, last_total);
  for (std::size_t c = 0; c < 3; ++c) CHECK(moment[c] == Approx(expected_moment[c]).epsilon(1e-9).margin(1e-12));
}

TEST_CASE("bad calls are refused with the coupling error codes", "[liggghts]") {
  Setup setup;
  auto backend = liggghts::makeBackend(setup.study, setup.probe());
  auto code = [](auto&& call) {
    try {
      call();
    } catch (const adapter::CouplingError& e) {
      return e.code();
    }
    return adapter::ErrorCode::Internal;
  };
  CHECK(code([&] { backend->nodeForces("no-such-tool"); }) == adapter::ErrorCode::UnknownGeometry);
  CHECK(code([&] { backend->setNodePositions("tool", {1.0, 2.0}); }) == adapter::ErrorCode::SizeMismatch);
  auto xyz = backend->nodePositions("tool");
  xyz[4] = std::nan("");
  CHECK(code([&] { backend->setNodePositions("tool", xyz); }) == adapter::ErrorCode::BadRequest);
  CHECK(code([&] { backend->simulate(-1.0); }) == adapter::ErrorCode::BadRequest);
  CHECK(code([&] { backend->checkpoint("x"); }) == adapter::ErrorCode::Unsupported);
  backend->shutdown();
  backend->shutdown();  // idempotent
  CHECK(code([&] { backend->time(); }) == adapter::ErrorCode::BadRequest);
}

TEST_CASE("a cone penetrometer pressed on a single sphere gets the hooke force kn delta", "[liggghts]") {
  Setup setup;  // its kn(): sphere against the tool steel
  study::Study& s = setup.study;
  s.kind = study::StudyKind::ConePenetration;
  study::Tool& cone = s.tools[0];
  support::usePaperCone(cone, 0.06);
  cone.geometry.keypoint_spacing_m = 0.005;
  cone.motion.stroke_m = 0;
  cone.motion.start_z_m = 0.08;
  const Vec3 tip = liggghts::toolStartOrigin(s, 0);
  // Right below the tip, overlapping it.
  auto backend = liggghts::makeBackend(s, probeAt({tip[0], tip[1] - (kRadius - kOverlap), tip[2]}));
  backend->simulate(backend->info().dem_time_step_s);
  const Vec3 total = sum(backend->nodeForces("tool", adapter::ForceMode::Instantaneous));
  // The tip vertex pushes the sphere down; the sphere pushes the cone up by kn delta.
  CHECK(total[1] == Approx(setup.kn() * kOverlap).epsilon(1e-6));
  CHECK(std::abs(total[0]) < 1e-9);
  CHECK(std::abs(total[2]) < 1e-9);
}
