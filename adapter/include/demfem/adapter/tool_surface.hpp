// The keypoint surface of any tool a DEM backend meshes (docs/architecture.md section 1): the plate
// of plate_surface.hpp or the cone penetrometer of Section 2.10.3 (Fig. 6c). Both DEM backends build
// their tool walls from it, so they mesh the same triangles.
//
// Contract
// - Tool local frame (docs/architecture.md section 10), metres: the tip at the origin, y up along the
//   tool. The cone's axis is the y axis: a cone of base radius R = sqrt(area / pi) and height
//   H = R / tan(apex / 2) (study ToolGeometry::coneRadius_m, coneHeight_m) from the tip y = 0 to its
//   base y = H, then a cylindrical shaft of radius R up to y = length, closed by a flat top disc.
// - Cone mesh: nodes on rings of n = max(8, round(2 pi R / spacing)) equal angles starting at +x
//   towards +z, at the circumradius R_n = R sqrt(2 pi / (n sin(2 pi / n))) at which the n-gon's area
//   is the projected area pi R^2 (so force / area is the resistance of the meshed cone); max(1, round(slant / spacing)) rings along the cone's slant (slant = R / sin(apex / 2)),
//   max(1, round((length - H) / spacing)) intervals along the shaft; node 0 is the tip, the last
//   node the centre of the top disc. Closed and consistently oriented (outward normals).
// - lo / hi: the local bounding box of the nodes (what a backend must keep inside its domain).
#pragma once

#include "demfem/study/study.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace demfem::adapter {

struct ToolSurface {
  std::vector<std::array<double, 3>> nodes;            // keypoints, local frame (m)
  std::vector<std::array<std::int32_t, 3>> triangles;  // outward normals
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};      // bounding box of the nodes
};

// The cone penetrometer: nominal base radius R, cone height, total length (tip to top) and spacing, in metres.
// Throws std::invalid_argument for non-positive sizes or a length not above the cone height.
ToolSurface makeConeSurface(double radius, double cone_height, double length, double spacing);

// The surface of `tool`: plate (makePlateSurface) or cone (makeConeSurface). Throws
// std::invalid_argument naming the tool for a geometry kind with no keypoint surface of its own
// (Gmsh, Matrix Market: their keypoints come from the FEM model).
ToolSurface toolSurface(const study::Tool& tool);

}  // namespace demfem::adapter
