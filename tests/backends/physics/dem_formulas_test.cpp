// The DEM formulas both backends share, each against a reference computed another way: the
// Rayleigh step against the root of Rayleigh's wave equation, LIGGGHTS' hooke stiffness against
// Hertz's peak overlap at the characteristic velocity, the closest point of a triangle against a
// brute-force search over the triangle.
#include "demfem/backends/physics/dem_formulas.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

using namespace demfem::physics;
using Catch::Detail::Approx;

namespace {

// Rayleigh wave speed over shear wave speed: the root xi in (0, 1) of
// (2 - xi^2)^2 = 4 sqrt(1 - xi^2) sqrt(1 - k xi^2), k = (1 - 2 nu) / (2 (1 - nu)), by bisection.
double rayleighSpeedRatio(double nu) {
  const double k = (1 - 2 * nu) / (2 * (1 - nu));
  const auto f = [&](double xi) {
    const double x2 = xi * xi;
    return (2 - x2) * (2 - x2) - 4 * std::sqrt(1 - x2) * std::sqrt(1 - k * x2);
  };
  double lo = 0.5, hi = 0.999999;  // f(lo) < 0 < f(hi) for 0 <= nu < 0.5 (0 is the trivial root)
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < 0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double distance(const Point3& a, const Point3& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

Point3 combine(const Point3& w, const Point3& a, const Point3& b, const Point3& c) {
  return {w[0] * a[0] + w[1] * b[0] + w[2] * c[0], w[0] * a[1] + w[1] * b[1] + w[2] * c[1],
          w[0] * a[2] + w[1] * b[2] + w[2] * c[2]};
}

}  // namespace

TEST_CASE("the Rayleigh step is pi R over the Rayleigh wave speed within the 0.1631 nu + 0.8766 fit", "[dem_physics]") {
  const double radius = 4.75e-3, density = 2600, youngs = 5e6;
  for (const double nu : {0.0, 0.2, 0.25, 0.3, 0.4, 0.49}) {
    const double shear = youngs / (2 * (1 + nu));
    const double exact = std::numbers::pi * radius / (rayleighSpeedRatio(nu) * std::sqrt(shear / density));
    // The linear fit of the speed ratio is good to about 0.5 % over 0 <= nu < 0.5.
    CHECK(rayleighTimeStep(radius, density, youngs, nu) == Approx(exact).epsilon(5e-3));
  }
}

TEST_CASE("LIGGGHTS hooke kn gives Hertz's peak overlap for an impact at the characteristic velocity", "[dem_physics]") {
  // Two spheres of radius 5 mm (R* = 2.5 mm, m* = m / 2) of E = 5e7 Pa, nu = 0.25 meeting at v = 1 m/s.
  const double r = 5e-3, mass = 2600 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
  const double y_eff = effectiveYoungs(5e7, 0.25, 5e7, 0.25);
  CHECK(y_eff == Approx(5e7 / (2 * (1 - 0.25 * 0.25))).epsilon(1e-14));
  const double r_eff = r / 2, m_eff = mass / 2, v = 1.0;
  const double kn = hookeNormalStiffness(y_eff, r_eff, m_eff, v);
  // Linear spring: m* v^2 / 2 = kn delta^2 / 2. Hertz: m* v^2 / 2 = 8/15 sqrt(R*) Y* delta^(5/2).
  const double linear_peak = v * std::sqrt(m_eff / kn);
  const double hertz_peak = std::pow(15.0 * m_eff * v * v / (16.0 * std::sqrt(r_eff) * y_eff), 0.4);
  CHECK(linear_peak == Approx(hertz_peak).epsilon(1e-12));
}

TEST_CASE("the closest point of a triangle matches a brute-force search and names its region", "[dem_physics]") {
  const Point3 a{0, 0, 0}, b{1, 0, 0.2}, c{0.3, 0.9, -0.1};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 2.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Point3 p{u(rng), u(rng), u(rng)};
    const TrianglePoint q = closestOnTriangle(p, a, b, c);
    const Point3 x = combine(q.weights, a, b, c);
    CHECK(q.weights[0] + q.weights[1] + q.weights[2] == Approx(1.0).epsilon(1e-14));
    for (const double w : q.weights) CHECK(w >= 0);
    double best = distance(p, a);
    const int steps = 400;
    for (int i = 0; i <= steps; ++i)
      for (int j = 0; i + j <= steps; ++j) {
        const Point3 w{1.0 - (i + j) / double(steps), i / double(steps), j / double(steps)};
        best = std::min(best, distance(p, combine(w, a, b, c)));
      }
    CHECK(distance(p, x) <= best + 1e-12);
    CHECK(distance(p, x) >= best - 5e-3);  // the grid's spacing bounds how much closer it can be
    const int nonzero = (q.weights[0] > 0) + (q.weights[1] > 0) + (q.weights[2] > 0);
    switch (q.region) {
      case TriangleRegion::A: case TriangleRegion::B: case TriangleRegion::C: CHECK(nonzero == 1); break;
      case TriangleRegion::AB: case TriangleRegion::AC: case TriangleRegion::BC: CHECK(nonzero <= 2); break;
      case TriangleRegion::Face: CHECK(nonzero == 3); break;
    }
  }
  // A point straight above the face, beyond each vertex and each edge.
  CHECK(closestOnTriangle({0.4, 0.3, 1.0}, a, b, c).region == TriangleRegion::Face);
  CHECK(closestOnTriangle({-1, -1, 0}, a, b, c).region == TriangleRegion::A);
  CHECK(closestOnTriangle({2, -0.5, 0.2}, a, b, c).region == TriangleRegion::B);
  CHECK(closestOnTriangle({0.3, 2, -0.1}, a, b, c).region == TriangleRegion::C);
  CHECK(closestOnTriangle({0.5, -1, 0.1}, a, b, c).region == TriangleRegion::AB);
  CHECK(closestOnTriangle({-1, 0.45, -0.05}, a, b, c).region == TriangleRegion::AC);
  const TrianglePoint bc = closestOnTriangle({1.5, 1.0, 0.05}, a, b, c);
  CHECK(bc.region == TriangleRegion::BC);
  CHECK(bc.weights[0] == 0);
}
