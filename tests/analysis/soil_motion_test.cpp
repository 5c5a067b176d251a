// Soil-motion measures on synthetic particle fields whose answers are known exactly.
#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/soil_motion.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>

using namespace demfem::analysis;

namespace {

constexpr double kD = 0.01;  // lattice spacing = particle diameter

// A simple cubic lattice of nx x ny x nz spheres of radius 5 mm, centres at (i + 0.5) kD; layer by
// height: `layers` equal slabs from the top (0 = top).
ParticleFrame lattice(int nx, int ny, int nz, int layers) {
  ParticleFrame f;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        f.position_m.insert(f.position_m.end(), {(i + 0.5) * kD, (j + 0.5) * kD, (k + 0.5) * kD});
        f.velocity_m_s.insert(f.velocity_m_s.end(), {0.0, 0.0, 0.0});
        f.radius_m.push_back(kD / 2);
        f.layer.push_back((ny - 1 - j) * layers / ny);
      }
  return f;
}

}  // namespace

TEST_CASE("the extent of a synthetic field with a known moving box is exact", "[analysis]") {
  ParticleFrame f = lattice(20, 8, 40, 1);
  // Particles with centres in x 65..125 mm, y 25..75 mm, z 105..245 mm (7 x 6 x 15) move at 30 mm/s
  // along z; the rest creep at 1 mm/s. Sphere bounds: x 60..130, y 20..80, z 100..250 mm.
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double* p = &f.position_m[3 * i];
    const bool inside = p[0] > 0.059 && p[0] < 0.131 && p[1] > 0.024 && p[1] < 0.076 && p[2] > 0.104 && p[2] < 0.246;
    f.velocity_m_s[3 * i + 2] = inside ? 0.030 : 0.001;
  }
  const auto e = movingExtent(f, 0.010, 0.080);
  CHECK(e.count == 7u * 6 * 15);
  CHECK(e.depth_m == Approx(0.060).epsilon(1e-12));   // surface 80 mm, lowest point 20 mm
  CHECK(e.length_m == Approx(0.150).epsilon(1e-12));
  CHECK(e.width_m == Approx(0.070).epsilon(1e-12));
  CHECK(movingExtent(f, 0.05, 0.08).count == 0);

  // In front of the box's front face (z 245 mm), within one diameter: nothing moves fast.
  const auto front = frontVelocityRange(f, Box{{0.06, 0.02, 0.25}, {0.13, 0.08, 0.26}});
  CHECK(front.count == 7u * 6);
  CHECK(front.max_m_s == Approx(0.001));
  const auto inside = frontVelocityRange(f, Box{{0.06, 0.02, 0.23}, {0.13, 0.08, 0.246}});
  CHECK(inside.min_m_s == Approx(0.030));
}

TEST_CASE("a vertical velocity section bins the mean speed of the particles on the plane", "[analysis]") {
  ParticleFrame f = lattice(4, 3, 5, 1);
  for (std::size_t i = 0; i < f.size(); ++i) f.velocity_m_s[3 * i] = f.position_m[3 * i + 2];  // |v| = z (per s)
  const auto map = velocitySection(f, Axis::X, 0.025, 0.006, 0.02);  // the plane x = 25 mm holds one column of centres
  CHECK(map.nu == 3);   // z centres 5 to 45 mm in cells [5, 25), [25, 45), [45, 65) mm
  CHECK(map.nv == 2);   // y centres 5 to 25 mm
  CHECK(map.at(0, 0) == Approx(0.010));  // z 5 and 15 mm
  CHECK(map.at(1, 1) == Approx(0.030));  // z 25 and 35 mm, y 25 mm
  CHECK(map.at(2, 0) == Approx(0.045));
  const auto horizontal = velocitySection(f, Axis::Y, 0.015, 0.004, 0.02);  // the middle row
  CHECK(horizontal.nv == 2);  // x centres 5 to 35 mm
  CHECK(horizontal.at(2, 1) == Approx(0.045));
}

TEST_CASE("mixing is 0 for untouched layers and reaches its maximum for a random permutation", "[analysis]") {
  ParticleFrame f = lattice(20, 12, 20, 4);  // 4 slabs of 3 particle rows
  const auto boundaries = layerBoundaries(f);
  REQUIRE(boundaries.size() == 3);
  CHECK(boundaries[0] == Approx(0.09));  // between the rows at 85 and 95 mm
  CHECK(mixingIndex(f, 0.04, boundaries) == 0.0);

  // Labels (ix + iy) mod 4: every 2 x 12 x 2 column holds each label 12 times, the global proportions -> 1.
  ParticleFrame dealt = f;
  for (std::size_t i = 0; i < dealt.size(); ++i)
    dealt.layer[i] = static_cast<int>(std::lround(dealt.position_m[3 * i] / kD - 0.5) + std::lround(dealt.position_m[3 * i + 1] / kD - 0.5)) % 4;
  CHECK(mixingIndex(dealt, 0.02, {}) == Approx(1.0).epsilon(1e-12));

  ParticleFrame shuffled = f;
  std::mt19937 rng(7);
  std::shuffle(shuffled.layer.begin(), shuffled.layer.end(), rng);
  const double random = mixingIndex(shuffled, 0.04, boundaries);
  CHECK(random > 0.9);  // 4800 particles, about 50 per cell: the finite-sample entropy deficit is a few %
  CHECK(random <= 1.0);
}
