// Shared test check: a keypoint surface (adapter/plate_surface.hpp, adapter/tool_surface.hpp) is
// closed and consistently oriented, and the volume it encloses.
#pragma once

#include <catch2/catch.hpp>

#include <map>
#include <utility>

namespace demfem::support {

// Volume enclosed by a triangulation with `nodes` and `triangles` (divergence theorem, m^3 for
// nodes in m); REQUIREs every directed edge once and its reverse once (closed, consistently
// oriented, outward normals for a positive volume).
template <class Surface>
double closedVolume(const Surface& s) {
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
  for (const auto& [edge, count] : edge_use) {
    REQUIRE(count == 1);
    REQUIRE(edge_use.count({edge.second, edge.first}) == 1);
  }
  return volume;
}

}  // namespace demfem::support
