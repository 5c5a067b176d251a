// Particle and mesh ParaView output of the built-in DEM (docs/builtin-dem.md, "Output"): XML VTK
// through vtkio (vtkio/include/demfem/vtkio/vtk_files.hpp), written atomically.
#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/adapter/output_files.hpp"
#include "demfem/vtkio/vtk_files.hpp"

namespace demfem::builtin {

void DemSimulation::writeParticlesVtk(const std::filesystem::path& file) const {
  const std::size_t n = particleCount();
  vtkio::Dataset d;
  d.time_s = time_;
  d.points = x_;
  vtkio::PointArray layer{"layer", 1, std::vector<double>(layer_.begin(), layer_.end()), vtkio::ValueType::Int32};
  vtkio::PointArray force{"force_N", 3, std::vector<double>(3 * n), vtkio::ValueType::Float64};
  for (std::size_t i = 0; i < n; ++i)  // the contact force: the last evaluation's total minus gravity
    for (int c = 0; c < 3; ++c) force.values[3 * i + c] = f_[3 * i + c] - mass_[i] * gravity_[c];
  d.arrays = {{"radius_m", 1, radius_, vtkio::ValueType::Float64}, {"velocity_m_s", 3, v_, vtkio::ValueType::Float64}, layer, force};
  adapter::writeFileAtomically(file, vtkio::encode(d, vtkio::Format::PolyData), adapter::Durability::Unsynced);
}

void DemSimulation::writeMeshVtk(int m, const std::filesystem::path& file) const {
  const TriangleMesh& mesh = meshes_[m];
  vtkio::Dataset d;
  d.time_s = time_;
  vtkio::PointArray displacement{"displacement_m", 3, {}, vtkio::ValueType::Float64};
  for (std::size_t k = 0; k < mesh.nodes.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      d.points.push_back(mesh_bin_nodes_.at(m)[k][c]);
      displacement.values.push_back(mesh.nodes[k][c] - mesh.rest_nodes[k][c]);
    }
  for (const auto& t : mesh.triangles) d.triangles.push_back({t[0], t[1], t[2]});
  d.arrays = {displacement, {"force_N", 3, mesh_force_[m], vtkio::ValueType::Float64}};
  adapter::writeFileAtomically(file, vtkio::encode(d, vtkio::Format::PolyData), adapter::Durability::Unsynced);
}

}  // namespace demfem::builtin
