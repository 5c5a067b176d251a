// Particle and mesh VTK output of the built-in DEM (docs/builtin-dem.md, "Output").
#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/adapter/output_files.hpp"

#include <sstream>

namespace demfem::builtin {

void DemSimulation::writeParticlesVtk(const std::filesystem::path& file) const {
  std::ostringstream out;
  const std::size_t n = particleCount();
  out << "# vtk DataFile Version 3.0\ndemfem builtin DEM particles t = " << time_ << " s\nASCII\nDATASET POLYDATA\n";
  out << "POINTS " << n << " double\n";
  out.precision(9);
  for (std::size_t i = 0; i < n; ++i) out << x_[3 * i] << ' ' << x_[3 * i + 1] << ' ' << x_[3 * i + 2] << '\n';
  out << "VERTICES " << n << ' ' << 2 * n << '\n';
  for (std::size_t i = 0; i < n; ++i) out << "1 " << i << '\n';
  out << "POINT_DATA " << n << "\nSCALARS radius_m double 1\nLOOKUP_TABLE default\n";
  for (std::size_t i = 0; i < n; ++i) out << radius_[i] << '\n';
  out << "SCALARS layer int 1\nLOOKUP_TABLE default\n";
  for (std::size_t i = 0; i < n; ++i) out << layer_[i] << '\n';
  out << "VECTORS velocity_m_s double\n";
  for (std::size_t i = 0; i < n; ++i) out << v_[3 * i] << ' ' << v_[3 * i + 1] << ' ' << v_[3 * i + 2] << '\n';
  adapter::writeFileAtomically(file, out.str());
}

void DemSimulation::writeMeshVtk(int m, const std::filesystem::path& file) const {
  std::ostringstream out;
  const auto& nodes = mesh_bin_nodes_.at(m);
  const auto& tris = meshes_[m].triangles;
  out << "# vtk DataFile Version 3.0\ndemfem builtin DEM mesh " << meshes_[m].name << " t = " << time_
      << " s\nASCII\nDATASET POLYDATA\nPOINTS " << nodes.size() << " double\n";
  out.precision(17);  // round trip: the FEM client's files of the same instant compare to round-off
  for (const auto& p : nodes) out << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
  out << "POLYGONS " << tris.size() << ' ' << 4 * tris.size() << '\n';
  for (const auto& t : tris) out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  out << "POINT_DATA " << nodes.size() << "\nVECTORS force_N double\n";
  const auto& f = mesh_force_[m];
  for (std::size_t k = 0; k < nodes.size(); ++k) out << f[3 * k] << ' ' << f[3 * k + 1] << ' ' << f[3 * k + 2] << '\n';
  adapter::writeFileAtomically(file, out.str());
}

}  // namespace demfem::builtin
