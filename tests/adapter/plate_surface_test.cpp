#include "demfem/adapter/plate_surface.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <map>

using demfem::adapter::makePlateSurface;

TEST_CASE("paper PMMA plate on the 5 mm grid has 41 x 9 x 2 keypoints", "[adapter]") {
  const auto s = makePlateSurface(0.200, 0.040, 0.004, 0.005);
  CHECK(s.nx == 9);
  CHECK(s.ny == 41);
  CHECK(s.nz == 2);
  CHECK(s.nodes.size() == 738u);
  // Two faces of 8 x 40 quads, two sides of 40 x 1, tip and top of 8 x 1: two triangles each.
  CHECK(s.triangles.size() == 2u * (2 * 8 * 40 + 2 * 40 + 2 * 8));
}

TEST_CASE("plate surface is closed and outward oriented: divergence theorem gives the volume", "[adapter]") {
  const double L = 0.2, W = 0.04, T = 0.012;
  const auto s = makePlateSurface(L, W, T, 0.005);
  double volume = 0;
  std::map<std::pair<int, int>, int> edge_use;
  for (const auto& t : s.triangles) {
    const auto& a = s.nodes[t[0]];
    const auto& b = s.nodes[t[1]];
    const auto& c = s.nodes[t[2]];
    volume += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
               a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
    for (int e = 0; e < 3; ++e) ++edge_use[{t[e], t[(e + 1) % 3]}];
  }
  CHECK(volume == Approx(L * W * T).epsilon(1e-12));
  // Closed and consistently oriented: every directed edge used once, its reverse once.
  for (const auto& [edge, count] : edge_use) {
    CHECK(count == 1);
    CHECK(edge_use.count({edge.second, edge.first}) == 1);
  }
  // Interior grid nodes (thickness 12 mm has interior layers) are not keypoints.
  CHECK(s.nz == 3);
  CHECK(s.id(4, 20, 1) == -1);
}

TEST_CASE("plate surface rejects non-positive sizes", "[adapter]") {
  CHECK_THROWS_WITH(makePlateSurface(0.2, -0.04, 0.003, 0.005),
                    Catch::Contains("must be > 0"));
}
