// STL import and VTK output of the builtin DEM.
#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/backends/builtin/triangle_mesh.hpp"
#include "demfem/vtkio/vtk_files.hpp"
#include "test_soil.hpp"

#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

using namespace demfem::builtin;

namespace {

// A tetrahedron with corners (0,0,0), (1,0,0), (0,1,0), (0,0,1) (file units): 4 faces, 4 nodes.
const Vec3 kCorners[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
const int kFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

std::filesystem::path tempFile(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "demfem-builtin-mesh-io-test";
  std::filesystem::create_directories(dir);
  return dir / name;
}

void writeAsciiStl(const std::filesystem::path& file) {
  std::ofstream out(file);
  out << "solid tetra\n";
  for (const auto& f : kFaces) {
    out << "  facet normal 0 0 0\n    outer loop\n";
    for (int v : f) out << "      vertex " << kCorners[v][0] << ' ' << kCorners[v][1] << ' ' << kCorners[v][2] << '\n';
    out << "    endloop\n  endfacet\n";
  }
  out << "endsolid tetra\n";
}

void writeBinaryStl(const std::filesystem::path& file, std::uint32_t claimed_triangles) {
  std::ofstream out(file, std::ios::binary);
  const std::string header(80, ' ');
  out.write(header.data(), 80);
  out.write(reinterpret_cast<const char*>(&claimed_triangles), 4);
  for (const auto& f : kFaces) {
    const float normal[3] = {0, 0, 0};
    out.write(reinterpret_cast<const char*>(normal), 12);
    for (int v : f) {
      const float xyz[3] = {static_cast<float>(kCorners[v][0]), static_cast<float>(kCorners[v][1]),
                            static_cast<float>(kCorners[v][2])};
      out.write(reinterpret_cast<const char*>(xyz), 12);
    }
    const std::uint16_t attribute = 0;
    out.write(reinterpret_cast<const char*>(&attribute), 2);
  }
}

void checkTetrahedron(const TriangleMesh& mesh, double scale) {
  REQUIRE(mesh.nodes.size() == 4);  // 12 corners merged into 4 shared nodes
  REQUIRE(mesh.triangles.size() == 4);
  for (const auto& corner : kCorners) {
    bool found = false;
    for (const auto& n : mesh.nodes)
      found = found || (n[0] == corner[0] * scale && n[1] == corner[1] * scale && n[2] == corner[2] * scale);
    CHECK(found);
  }
  // Every node is used by exactly three faces (closed tetrahedron).
  int uses[4] = {0, 0, 0, 0};
  for (const auto& t : mesh.triangles)
    for (int v : t) ++uses[v];
  for (int u : uses) CHECK(u == 3);
}

}  // namespace

TEST_CASE("ASCII and binary STL files give the same merged mesh in metres", "[builtin]") {
  const auto ascii = tempFile("tetra_ascii.stl");
  const auto binary = tempFile("tetra_binary.stl");
  writeAsciiStl(ascii);
  writeBinaryStl(binary, 4);
  checkTetrahedron(readStl(ascii, 0.001), 0.001);  // file in mm
  checkTetrahedron(readStl(binary, 0.001), 0.001);
  CHECK(readStl(ascii).name == "tetra_ascii");
}

TEST_CASE("a truncated or missing STL file is refused with its name and the problem", "[builtin]") {
  const auto truncated = tempFile("tetra_truncated.stl");
  writeBinaryStl(truncated, 5);  // header claims one triangle more than the file holds
  CHECK_THROWS_WITH(readStl(truncated), Catch::Contains("tetra_truncated.stl") && Catch::Contains("truncated"));
  CHECK_THROWS_WITH(readStl(tempFile("absent.stl")), Catch::Contains("absent.stl") && Catch::Contains("cannot open"));
}

TEST_CASE("VTK files of particles and meshes hold the positions, connectivity, velocities and node forces", "[builtin]") {
  using namespace demfem::builtin::testing;
  DemSimulation sim(makeSoil({}), box(1.0), 1);
  const ParticleState particles[3] = {{{0.1, 0.2, 0.3}, {1, 0, 0}, {0, 0, 0}, 0.005, 0, 0},
                                      {{-0.1, 0.0, 0.2}, {0, 2, 0}, {0, 0, 0}, 0.006, 0, 0},
                                      {{0.0, -0.3, 0.0}, {0, 0, 3}, {0, 0, 0}, 0.007, 0, 0}};
  for (const auto& p : particles) sim.addParticle(p);
  TriangleMesh tetra = readStl([] {
    const auto f = tempFile("tetra_for_vtk.stl");
    writeAsciiStl(f);
    return f;
  }(), 0.01);
  sim.addMesh(tetra);

  // Read back by VTK's own XML reader (vtkio::read) with the declared arrays and sizes.
  const auto pfile = tempFile("particles.vtp");
  sim.writeParticlesVtk(pfile);
  const auto p = demfem::vtkio::read(pfile);
  CHECK(p.time_s == sim.time());
  REQUIRE(p.pointCount() == 3);
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c) CHECK(p.points[3 * i + c] == particles[i].x[c]);
  CHECK(p.array("velocity_m_s").values[8] == 3.0);
  CHECK(p.array("radius_m").values == std::vector<double>{0.005, 0.006, 0.007});
  CHECK(p.array("layer").type == demfem::vtkio::ValueType::Int32);
  CHECK(p.array("force_N").components == 3);

  const auto mfile = tempFile("mesh.vtp");
  sim.writeMeshVtk(0, mfile);
  const auto m = demfem::vtkio::read(mfile);
  CHECK(m.pointCount() == 4);
  REQUIRE(m.triangles.size() == 4);
  for (std::size_t t = 0; t < 4; ++t)
    for (int k = 0; k < 3; ++k) CHECK(m.triangles[t][k] == tetra.triangles[t][k]);
  CHECK(m.array("force_N").values.size() == 12);
  CHECK(m.array("displacement_m").values == std::vector<double>(12, 0.0));
}
