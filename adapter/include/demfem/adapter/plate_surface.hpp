// The keypoint surface of a plate tool: the nodes and triangles both sides of the coupling share
// (paper Fig. 2 and Fig. 4e; docs/architecture.md section 4). The DEM backends build the tool wall from it,
// the FEM client meshes the plate so that these keypoints are nodes of its mesh.
//
// Contract
// - Tool local frame (docs/architecture.md section 10), metres: x across the width in [-W/2, W/2], y along the
//   length in [0, L] (tip y = 0, top y = L), z through the thickness in [-T/2, T/2]; the tool travels
//   in +z, so the face z = +T/2 is the front (soil-engaging) face.
// - Keypoints are the nodes of the grid that lie on the surface. Along each edge the grid has
//   max(1, round(edge / spacing)) equal intervals, so a 200 x 40 x 3 mm plate on a 5 mm grid has
//   41 x 9 x 2 = 738 keypoints (the 3 mm thickness is one interval).
// - Node ids are ordered z-major, then y, then x (id = (k * ny + j) * nx + i over the grid, counting
//   surface nodes only); every surface triangle is listed once with its normal pointing out of the
//   plate (right-hand rule), so the triangulation is closed and consistently oriented.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace demfem::adapter {

struct PlateSurface {
  int nx = 0, ny = 0, nz = 0;                           // grid nodes along x, y, z
  std::vector<std::array<double, 3>> nodes;             // keypoints, local frame (m)
  std::vector<std::array<std::int32_t, 3>> triangles;   // outward normals
  std::vector<std::array<int, 3>> grid_index;           // (i, j, k) of each keypoint
  // Keypoint id of grid node (i, j, k), or -1 if it is interior (not on the surface).
  std::int32_t id(int i, int j, int k) const;

  std::vector<std::int32_t> index_;                     // grid -> keypoint id (-1 interior)
};

// Builds the keypoint surface of an L x W x T plate on a grid of about `spacing` (all in metres).
// Throws std::invalid_argument for non-positive sizes.
PlateSurface makePlateSurface(double length, double width, double thickness, double spacing);

}  // namespace demfem::adapter
