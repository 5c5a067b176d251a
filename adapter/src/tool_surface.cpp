#include "demfem/adapter/tool_surface.hpp"

#include "demfem/adapter/plate_surface.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace demfem::adapter {

namespace {

int intervals(double length, double spacing) { return std::max(1, static_cast<int>(std::lround(length / spacing))); }

void setBounds(ToolSurface& s) {
  s.lo = s.hi = s.nodes.front();
  for (const auto& n : s.nodes)
    for (int c = 0; c < 3; ++c) {
      s.lo[c] = std::min(s.lo[c], n[c]);
      s.hi[c] = std::max(s.hi[c], n[c]);
    }
}

}  // namespace

ToolSurface makeConeSurface(double radius, double cone_height, double length, double spacing) {
  if (!(radius > 0) || !(cone_height > 0) || !(spacing > 0) || !(length > cone_height))
    throw std::invalid_argument("cone surface: radius, cone height and spacing must be > 0 and the length above the cone height");
  const int around = std::max(8, static_cast<int>(std::lround(2 * std::numbers::pi * radius / spacing)));
  const int cone_rings = intervals(std::hypot(radius, cone_height), spacing);
  const int shaft_rings = intervals(length - cone_height, spacing);
  const double ring_radius = radius * std::sqrt(2 * std::numbers::pi / (around * std::sin(2 * std::numbers::pi / around)));
  ToolSurface s;
  s.nodes.push_back({0, 0, 0});
  // Ring r (1-based): on the cone for r <= cone_rings, on the shaft above.
  const auto ringNode = [&](int r, int k) { return static_cast<std::int32_t>(1 + (r - 1) * around + (k % around)); };
  for (int r = 1; r <= cone_rings + shaft_rings; ++r) {
    const bool on_cone = r <= cone_rings;
    const double y = on_cone ? cone_height * r / cone_rings : cone_height + (length - cone_height) * (r - cone_rings) / shaft_rings;
    const double rr = on_cone ? ring_radius * r / cone_rings : ring_radius;
    for (int k = 0; k < around; ++k) {
      const double a = 2 * std::numbers::pi * k / around;
      s.nodes.push_back({rr * std::cos(a), y, rr * std::sin(a)});
    }
  }
  const auto top = static_cast<std::int32_t>(s.nodes.size());
  s.nodes.push_back({0, length, 0});
  const int rings = cone_rings + shaft_rings;
  for (int k = 0; k < around; ++k) {
    s.triangles.push_back({0, ringNode(1, k), ringNode(1, k + 1)});
    for (int r = 1; r < rings; ++r) {
      s.triangles.push_back({ringNode(r, k), ringNode(r + 1, k), ringNode(r + 1, k + 1)});
      s.triangles.push_back({ringNode(r, k), ringNode(r + 1, k + 1), ringNode(r, k + 1)});
    }
    s.triangles.push_back({top, ringNode(rings, k + 1), ringNode(rings, k)});
  }
  setBounds(s);
  return s;
}

ToolSurface toolSurface(const study::Tool& tool) {
  const auto& g = tool.geometry;
  switch (g.kind) {
    case study::GeometryKind::Plate: {
      const PlateSurface plate = makePlateSurface(g.length_m, g.width_m, g.thickness_m, g.keypoint_spacing_m);
      ToolSurface s{plate.nodes, plate.triangles, {}, {}};
      setBounds(s);
      return s;
    }
    case study::GeometryKind::Cone:
      return makeConeSurface(g.coneRadius_m(), g.coneHeight_m(), g.length_m, g.keypoint_spacing_m);
    case study::GeometryKind::Gmsh:
    case study::GeometryKind::MatrixMarket:
      break;
  }
  throw std::invalid_argument("tool '" + tool.name + "': a DEM backend meshes plate and cone tools only (keypoint surface)");
}

}  // namespace demfem::adapter
