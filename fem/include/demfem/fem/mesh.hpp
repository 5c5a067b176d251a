// demfem FEM meshes: quadratic solid elements for the tool (paper Section 2.6; docs/architecture.md section 4).
//
// Contract
// - Units: metres. Frame: the tool local frame (docs/architecture.md section 10): x across the width, y along
//   the length (tip y = 0, top y = L), z through the thickness (the travel direction).
// - Node order inside an element follows CalculiX/Abaqus (C3D20: corners 0-7 as two faces 0-3 and
//   4-7, then mid-edges 8-11 of the first face, 12-15 of the second, 16-19 of the edges between them;
//   C3D10: corners 0-3, then mid-edges (0,1) (1,2) (2,0) (0,3) (1,3) (2,3)). The Gmsh reader converts
//   Gmsh's own order to this one, so every mesh here can be written to a CalculiX deck unchanged.
// - Elements are isoparametric with straight or curved edges; a mesh must have positive Jacobians
//   (assembly checks and throws naming the element otherwise).
#pragma once

#include <Eigen/Core>

#include <filesystem>
#include <vector>

namespace demfem::fem {

enum class ElementType { Hex20, Tet10 };

// Nodes per element of `type` (20 or 10).
int nodesPerElement(ElementType type);

struct Element {
  ElementType type = ElementType::Hex20;
  std::vector<int> nodes;  // node indices into Mesh::nodes, CalculiX order (see contract)
};

struct Mesh {
  std::vector<Eigen::Vector3d> nodes;  // m, tool local frame
  std::vector<Element> elements;
};

// A structured Hex20 mesh of an L x W x T plate whose corner nodes are the grid of
// adapter::makePlateSurface(L, W, T, spacing): max(1, round(edge / spacing)) elements along each
// edge. `keypoint_nodes[k]` is the mesh node of keypoint id k of that plate surface, so the keypoint
// ids (and the DEM side's triangles) are shared. All sizes in metres; throws std::invalid_argument
// for non-positive sizes.
struct PlateMesh {
  Mesh mesh;
  std::vector<int> keypoint_nodes;
};
PlateMesh makePlateMesh(double length, double width, double thickness, double spacing);

// Reads a Gmsh mesh file, format 4.1 ASCII ($MeshFormat 4.1 0 8), keeping its quadratic volume
// elements (Gmsh type 17 = 20-node hexahedron, type 11 = 10-node tetrahedron) and the nodes they
// use. Node coordinates are taken in the file's unit times `scale_to_m` (1 if the file is in m,
// 1e-3 for mm). Throws std::runtime_error naming the file and line for unreadable or unsupported
// content (binary files, other versions, linear or other element types in the volume).
Mesh readGmshMesh(const std::filesystem::path& file, double scale_to_m);

}  // namespace demfem::fem
