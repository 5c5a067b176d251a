#include "demfem/adapter/tool_surface.hpp"
#include "support/closed_surface.hpp"
#include "support/study_in_code.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

using namespace demfem;

using support::closedVolume;

TEST_CASE("the paper's 5 cm^2 60 deg penetrometer is a closed cone and shaft of the projected area", "[adapter]") {
  study::Tool tool;
  tool.name = "cone1";
  support::usePaperCone(tool, 0.1);
  tool.geometry.keypoint_spacing_m = 0.005;
  const auto s = adapter::toolSurface(tool);
  const double r = std::sqrt(5e-4 / std::numbers::pi), h = r / std::tan(std::numbers::pi / 6);
  CHECK(tool.geometry.coneHeight_m() == Approx(h).epsilon(1e-15));
  // 16 nodes around (2 pi 12.6 mm / 5 mm = 15.9), 5 rings on the 25.2 mm slant, 16 shaft intervals.
  const int around = 16, rings = 5 + 16;
  REQUIRE(s.nodes.size() == static_cast<std::size_t>(2 + around * rings));
  CHECK(s.triangles.size() == static_cast<std::size_t>(2 * around * rings));
  // The 16-gon has the projected area: volume = area (H / 3 + L - H) exactly.
  CHECK(closedVolume(s) == Approx(5e-4 * (h / 3 + 0.1 - h)).epsilon(1e-12));
  CHECK(s.nodes.front() == std::array<double, 3>{0, 0, 0});
  CHECK(s.hi[1] == Approx(0.1).epsilon(1e-15));
  CHECK(s.lo[0] == Approx(-s.hi[0]).epsilon(1e-12));
}

TEST_CASE("a plate's tool surface is its keypoint surface with its bounding box", "[adapter]") {
  study::Tool tool;
  tool.geometry.kind = study::GeometryKind::Plate;
  const auto s = adapter::toolSurface(tool);  // 200 x 40 x 3 mm
  CHECK(s.nodes.size() == 738u);
  CHECK(closedVolume(s) == Approx(0.2 * 0.04 * 0.003).epsilon(1e-12));
  CHECK(s.lo == std::array<double, 3>{-0.02, 0, -0.0015});
  CHECK(s.hi == std::array<double, 3>{0.02, 0.2, 0.0015});
}

TEST_CASE("tool surfaces refuse geometries they cannot mesh, naming the tool", "[adapter]") {
  study::Tool tool;
  tool.name = "from_gmsh";
  tool.geometry.kind = study::GeometryKind::Gmsh;
  CHECK_THROWS_WITH(adapter::toolSurface(tool), Catch::Contains("tool 'from_gmsh'"));
  CHECK_THROWS_WITH(adapter::makeConeSurface(0.01, 0.02, 0.015, 0.005), Catch::Contains("above the cone height"));
}
