#include "demfem/adapter/plate_surface.hpp"
#include "support/closed_surface.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>

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
  // Closed and consistently oriented: every directed edge used once, its reverse once.
  CHECK(demfem::support::closedVolume(s) == Approx(L * W * T).epsilon(1e-12));
  // Interior grid nodes (thickness 12 mm has interior layers) are not keypoints.
  CHECK(s.nz == 3);
  CHECK(s.id(4, 20, 1) == -1);
}

TEST_CASE("plate surface rejects non-positive sizes", "[adapter]") {
  CHECK_THROWS_WITH(makePlateSurface(0.2, -0.04, 0.003, 0.005),
                    Catch::Contains("must be > 0"));
}
