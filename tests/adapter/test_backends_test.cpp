#include "demfem/adapter/test_backends.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>

using namespace demfem::adapter;
namespace fs = std::filesystem;

namespace {

std::vector<demfem::study::Tool> pmmaTool() {
  demfem::study::Tool tool;  // 200 x 40 mm plate, 5 mm grid
  tool.geometry.thickness_m = 0.004;
  return {tool};
}

double sumZ(const NodeArray& f) {
  double s = 0;
  for (std::size_t i = 2; i < f.size(); i += 3) s += f[i];
  return s;
}

}  // namespace

TEST_CASE("harmonic backend: interval-mean force is the exact time average of F sin(2 pi f t)", "[adapter]") {
  TestLoad load;
  load.force_N = -8.0;
  load.frequency_Hz = 37.0;
  load.dem_time_step_s = 1e-6;
  auto api = makeTestBackend("harmonic", pmmaTool(), load);
  api->simulate(0.0123);
  const double t0 = api->time();
  api->simulate(0.0017);
  const double t1 = api->time();
  CHECK(t1 - t0 == Approx(0.0017).epsilon(1e-12));
  // Independent reference: composite Simpson rule of the instantaneous total, 2000 panels
  // (error ~ (w h)^4 / 180 relative, far below the 1e-9 tolerance).
  const double w = 2 * std::numbers::pi * load.frequency_Hz;
  const int n = 2000;
  double simpson = 0;
  for (int i = 0; i <= n; ++i) {
    const double t = t0 + (t1 - t0) * i / n;
    simpson += (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2)) * load.force_N * std::sin(w * t);
  }
  simpson /= 3.0 * n;
  CHECK(sumZ(api->nodeForces("tool")) == Approx(simpson).epsilon(1e-9));
  CHECK(sumZ(api->nodeForces("tool", ForceMode::Instantaneous)) ==
        Approx(load.force_N * std::sin(w * t1)).epsilon(1e-12));
}

TEST_CASE("harmonic backend: force depends on node position as (1 + x / W), only on the tip row", "[adapter]") {
  auto api = makeTestBackend("harmonic", pmmaTool(), TestLoad{});
  api->simulate(0.004);
  const NodeArray x = api->nodePositions("tool"), f = api->nodeForces("tool", ForceMode::Instantaneous);
  REQUIRE(x.size() == 738 * 3);
  int loaded = 0;
  double ratio_ref = 0;
  for (std::size_t i = 0; i < 738; ++i) {
    CHECK(f[3 * i] == 0.0);
    CHECK(f[3 * i + 1] == 0.0);
    if (x[3 * i + 1] > 1e-12) {
      CHECK(f[3 * i + 2] == 0.0);
      continue;
    }
    ++loaded;
    const double ratio = f[3 * i + 2] / (1.0 + x[3 * i] / 0.040);
    if (loaded == 1) ratio_ref = ratio;
    CHECK(ratio == Approx(ratio_ref).epsilon(1e-14));
  }
  CHECK(loaded == 18);  // 9 nodes across the width, two faces
}

TEST_CASE("spring backend pulls the tip row back to its undeformed position", "[adapter]") {
  TestLoad load;
  load.stiffness_N_m = 2000.0;
  auto api = makeTestBackend("spring", pmmaTool(), load);
  NodeArray x = api->nodePositions("tool");
  for (std::size_t i = 2; i < x.size(); i += 3) x[i] += 0.001;  // whole tool moved 1 mm in +z
  api->setNodePositions("tool", x);
  api->simulate(1e-3);
  CHECK(sumZ(api->nodeForces("tool")) == Approx(-2.0).epsilon(1e-12));  // -k * 1 mm
}

TEST_CASE("constant backend: the tip row carries F in total at all times", "[adapter]") {
  auto api = makeTestBackend("constant", pmmaTool(), TestLoad{});
  CHECK(sumZ(api->nodeForces("tool")) == Approx(TestLoad{}.force_N).epsilon(1e-14));
  api->simulate(0.5);
  CHECK(sumZ(api->nodeForces("tool")) == Approx(TestLoad{}.force_N).epsilon(1e-14));
}

TEST_CASE("test backends reject bad calls with coded errors", "[adapter]") {
  auto api = makeTestBackend("constant", pmmaTool(), TestLoad{});
  const auto code = [&](auto&& call) {
    try {
      call();
    } catch (const CouplingError& e) {
      return e.code();
    }
    return ErrorCode::Internal;
  };
  CHECK(code([&] { api->nodeForces("plough"); }) == ErrorCode::UnknownGeometry);
  CHECK(code([&] { api->setNodePositions("tool", NodeArray(9, 0.0)); }) == ErrorCode::SizeMismatch);
  NodeArray x = api->nodePositions("tool");
  x[4] = std::nan("");
  CHECK(code([&] { api->setNodePositions("tool", x); }) == ErrorCode::BadRequest);
  CHECK(code([&] { api->simulate(-1.0); }) == ErrorCode::BadRequest);
  CHECK(code([] { makeTestBackend("quantum", {}, TestLoad{}); }) == ErrorCode::Unsupported);
  api->shutdown();
  api->shutdown();  // idempotent
  CHECK(code([&] { api->time(); }) == ErrorCode::BadRequest);
}

TEST_CASE("a restored test backend continues bit-identically", "[adapter]") {
  const fs::path file = fs::temp_directory_path() / ("demfem-test-backend-" + std::to_string(std::random_device{}()) + ".ckpt");
  auto a = makeTestBackend("harmonic", pmmaTool(), TestLoad{});
  NodeArray x = a->nodePositions("tool");
  x[5] += 1e-4;
  a->setNodePositions("tool", x);
  a->setRigidMotion("tool", {{0.1, 0.2, 0.3}, {0, 0, 0.031}, 0.5});
  a->simulate(0.0031);
  a->checkpoint(file);
  a->simulate(0.001);
  const NodeArray fa = a->nodeForces("tool");

  auto b = makeTestBackend("harmonic", pmmaTool(), TestLoad{});
  b->restore(file);
  CHECK(b->nodePositions("tool") == x);
  CHECK(b->rigidMotion("tool").velocity_m_s[2] == 0.031);
  b->simulate(0.001);
  CHECK(b->nodeForces("tool") == fa);
  CHECK(b->time() == a->time());

  auto c = makeTestBackend("spring", pmmaTool(), TestLoad{});
  CHECK_THROWS_AS(c->restore(file), CouplingError);
  fs::remove(file);
}
