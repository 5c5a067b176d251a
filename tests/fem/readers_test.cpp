// Readers: Gmsh msh 4.1 ASCII (quadratic hex/tet, node order converted) and MatrixMarket M, K with a
// keypoint list (the Ansys route of paper Section 2.7).
#include "fem_test_tools.hpp"

#include "demfem/fem/model.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

using namespace demfem;
using namespace demfem::fem;

namespace {

std::filesystem::path tempFile(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("demfem_fem_test_" + name);
}

void writeText(const std::filesystem::path& file, const std::string& text) {
  std::ofstream(file) << text;
}

// Unit-cube Hex20 and unit Tet10, node tags 1.. in GMSH's node order (Gmsh reference manual,
// "Node ordering": hexahedron edges 01 03 04 12 15 23 26 37 45 47 56 67; tetrahedron edges 01 12 02
// 03 23 13).
const char* kGmshHex20 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Nodes
1 20 1 20
3 1 0 20
1
2
3
4
5
6
7
8
9
10
11
12
13
14
15
16
17
18
19
20
0 0 0
1 0 0
1 1 0
0 1 0
0 0 1
1 0 1
1 1 1
0 1 1
0.5 0 0
0 0.5 0
0 0 0.5
1 0.5 0
1 0 0.5
0.5 1 0
1 1 0.5
0 1 0.5
0.5 0 1
0 0.5 1
1 0.5 1
0.5 1 1
$EndNodes
$Elements
1 1 1 1
3 1 17 1
1 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20
$EndElements
)";

const char* kGmshTet10 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Nodes
1 10 1 10
3 1 0 10
1
2
3
4
5
6
7
8
9
10
0 0 0
1 0 0
0 1 0
0 0 1
0.5 0 0
0.5 0.5 0
0 0.5 0
0 0 0.5
0 0.5 0.5
0.5 0 0.5
$EndNodes
$Elements
2 2 1 2
2 1 9 1
1 1 2 3 5 6 7
3 1 11 1
2 1 2 3 4 5 6 7 8 9 10
$EndElements
)";

// Every mid-edge node of every element sits at the midpoint of its two corners (CalculiX order).
void checkMidEdgeNodes(const Mesh& mesh) {
  static constexpr int hex_edges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6}, {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  static constexpr int tet_edges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  for (const Element& e : mesh.elements) {
    const bool hex = e.type == ElementType::Hex20;
    for (int m = 0; m < (hex ? 12 : 6); ++m) {
      const auto& edge = hex ? hex_edges[m] : tet_edges[m];
      const Eigen::Vector3d mid = 0.5 * (mesh.nodes[e.nodes[edge[0]]] + mesh.nodes[e.nodes[edge[1]]]);
      CHECK((mesh.nodes[e.nodes[(hex ? 8 : 4) + m]] - mid).norm() < 1e-15);
    }
  }
}

double totalMass(const Mesh& mesh) {
  const Assembled a = assemble(mesh, {1e9, 0.3, 1000}, HexIntegration::Full);
  return a.M.sum() / 3;
}

void writeMarket(const std::filesystem::path& file, const SparseMatrix& A) {
  std::ofstream out(file);
  out.precision(17);
  out << "%%MatrixMarket matrix coordinate real symmetric\n% exported for a test\n";
  long entries = 0;
  for (int c = 0; c < A.outerSize(); ++c)
    for (SparseMatrix::InnerIterator it(A, c); it; ++it) entries += it.row() >= it.col();
  out << A.rows() << " " << A.cols() << " " << entries << "\n";
  for (int c = 0; c < A.outerSize(); ++c)
    for (SparseMatrix::InnerIterator it(A, c); it; ++it)
      if (it.row() >= it.col()) out << it.row() + 1 << " " << it.col() + 1 << " " << it.value() << "\n";
}

}  // namespace

TEST_CASE("Gmsh 4.1 quadratic hexahedra and tetrahedra are read in CalculiX node order", "[fem]") {
  const auto hex_file = tempFile("hex20.msh"), tet_file = tempFile("tet10.msh");
  writeText(hex_file, kGmshHex20);
  writeText(tet_file, kGmshTet10);
  const Mesh hex = readGmshMesh(hex_file, 1e-3);  // file in mm
  REQUIRE(hex.elements.size() == 1);
  REQUIRE(hex.nodes.size() == 20);
  checkMidEdgeNodes(hex);
  CHECK(totalMass(hex) == Approx(1000 * 1e-9).epsilon(1e-12));  // 1 mm^3 at 1000 kg/m^3
  const Mesh tet = readGmshMesh(tet_file, 1.0);
  REQUIRE(tet.elements.size() == 1);  // the surface triangle (type 9) is skipped
  checkMidEdgeNodes(tet);
  CHECK(totalMass(tet) == Approx(1000.0 / 6).epsilon(1e-12));
}

TEST_CASE("unsupported Gmsh content is rejected with file and line", "[fem]") {
  const auto file = tempFile("bad.msh");
  writeText(file, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n");
  CHECK_THROWS_WITH(readGmshMesh(file, 1.0), Catch::Contains("bad.msh:2") && Catch::Contains("need 4.1"));
  std::string linear = kGmshHex20;
  linear.replace(linear.find("3 1 17 1"), 8, "3 1 5 1");
  writeText(file, linear);
  CHECK_THROWS_WITH(readGmshMesh(file, 1.0), Catch::Contains("volume element type 5 is not supported"));
}

TEST_CASE("externally assembled M and K with a keypoint list reduce like the built-in model", "[fem]") {
  const study::Tool tool = testing::smallStrip();
  const FullModel built = buildPlateModel(tool);
  const auto m_file = tempFile("M.mtx"), k_file = tempFile("K.mtx"), kp_file = tempFile("keypoints.txt");
  writeMarket(m_file, built.M);
  writeMarket(k_file, built.K);
  {
    std::ofstream kp(kp_file);
    kp.precision(17);
    kp << "# node x_m y_m z_m\n";
    for (std::size_t k = 0; k < built.keypoint_nodes.size(); ++k)
      kp << built.keypoint_nodes[k] << " " << built.keypoints.row(static_cast<Eigen::Index>(k)) << "\n";
  }
  const FullModel read = readMatrixMarketModel(m_file, k_file, kp_file, tool.constraints);
  CHECK(read.constraints.fixed_dofs == built.constraints.fixed_dofs);
  CHECK(read.constraints.load_cell_dofs == built.constraints.load_cell_dofs);
  const Modes a = naturalModes(reduce(built), 2), b = naturalModes(reduce(read), 2);
  CHECK(b.frequencies_Hz[0] == Approx(a.frequencies_Hz[0]).epsilon(1e-9));
  CHECK(b.frequencies_Hz[1] == Approx(a.frequencies_Hz[1]).epsilon(1e-9));

  SECTION("an explicit constraint on a node that is not a keypoint is rejected, naming it") {
    std::ofstream(kp_file, std::ios::app) << "fix 1 xyz\n";  // node 1: a mid-side node
    const FullModel bad = readMatrixMarketModel(m_file, k_file, kp_file, tool.constraints);
    CHECK_THROWS_WITH(reduce(bad), Catch::Contains("3 constrained DOF(s) are not keypoint DOFs") &&
                                       Catch::Contains("node 1") && Catch::Contains("DOF y"));
  }
  SECTION("a malformed keypoint line names file and line") {
    std::ofstream(kp_file, std::ios::app) << "12 0.1 oops\n";
    CHECK_THROWS_WITH(readMatrixMarketModel(m_file, k_file, kp_file, tool.constraints),
                      Catch::Contains("keypoints.txt:" + std::to_string(built.keypoint_nodes.size() + 2)));
  }
}
