#include "demfem/backends/builtin/backend.hpp"

#include "demfem/adapter/checkpoint_file.hpp"
#include "demfem/adapter/output_files.hpp"
#include "demfem/adapter/tool_surface.hpp"
#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/study/tool_motion.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

namespace demfem::builtin {

namespace {

using adapter::CouplingError;
using adapter::ErrorCode;

constexpr char kCheckpointKind[] = "builtin";

class BuiltinBackend final : public adapter::CouplingApi {
 public:
  BuiltinBackend(const study::Study& study, const adapter::SettledSoil& soil, std::string soil_record)
      : study_(study), sim_(study.soil, binDomain(study.soil), study.dem.threads), soil_record_(std::move(soil_record)) {
    loadSettledBed(sim_, study.soil, soil);
    for (const auto& tool : study.tools) {
      TriangleMesh mesh = toolMesh(tool);
      mesh.material = sim_.materials().index(tool.dem_material);
      const int m = sim_.addMesh(std::move(mesh));
      meshes_[tool.name] = m;
      // At rest at the plan's start pose (coupling_api.hpp, "After construction"); only the client moves it.
      sim_.setMeshMotion(m, study::planToolMotion(study, tool).start_m, {0, 0, 0}, 0);
    }
    setRunTimeStep(sim_, study);
    if (study.output.vtk_every > 0) {
      vtk_interval_ = study.output.vtk_every * study.fem.dt_s;
      next_vtk_ = sim_.time();
      openVtkSeries(std::nullopt);
    }
    last_positions_time_ = sim_.time();
  }

  adapter::BackendInfo info() override {
    alive();
    return {"builtin", "0.1", 1, sim_.timeStep(), soil_record_};
  }

  std::vector<adapter::GeometryInfo> geometries() override {
    alive();
    std::vector<adapter::GeometryInfo> out;
    for (const auto& tool : study_.tools) {
      const auto& mesh = sim_.mesh(meshes_.at(tool.name));
      out.push_back({tool.name, static_cast<std::int32_t>(mesh.nodes.size()), mesh.triangles});
    }
    return out;
  }

  double time() override {
    alive();
    return sim_.time();
  }

  adapter::NodeArray nodePositions(const std::string& geometry) override {
    const auto& mesh = sim_.mesh(meshOf(geometry));
    adapter::NodeArray out;
    out.reserve(mesh.nodes.size() * 3);
    for (const auto& n : mesh.nodes) out.insert(out.end(), n.begin(), n.end());
    return out;
  }

  adapter::NodeArray nodeForces(const std::string& geometry, adapter::ForceMode mode) override {
    const int m = meshOf(geometry);
    if (mode == adapter::ForceMode::Instantaneous) return sim_.nodeForces(m);
    return interval_mean_.count(m) ? interval_mean_.at(m) : adapter::NodeArray(sim_.nodeForces(m).size(), 0.0);
  }

  void setNodePositions(const std::string& geometry, const adapter::NodeArray& xyz) override {
    const int m = meshOf(geometry);
    const auto n = sim_.mesh(m).nodes.size();
    if (xyz.size() != 3 * n)
      throw CouplingError(ErrorCode::SizeMismatch, "builtin DEM: geometry '" + geometry + "' has " + std::to_string(n) +
                                                       " nodes (" + std::to_string(3 * n) + " values), got " +
                                                       std::to_string(xyz.size()) + " values");
    std::vector<Vec3> local(n);
    for (std::size_t k = 0; k < n; ++k) {
      local[k] = {xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]};
      for (double c : local[k])
        if (!std::isfinite(c))
          throw CouplingError(ErrorCode::BadRequest, "builtin DEM: geometry '" + geometry + "' node " + std::to_string(k) +
                                                         " position is not finite");
    }
    sim_.setNodePositions(m, local, sim_.time() - last_positions_time_);
    last_positions_time_ = sim_.time();
  }

  void simulate(double duration_s) override {
    alive();
    const long steps = static_cast<long>(adapter::demStepCount(duration_s, sim_.timeStep(), sim_.stepCount()));
    if (steps == 0) return;
    sim_.resetNodeImpulse();
    try {
      long done = 0;
      while (done < steps) {
        long chunk = steps - done;
        if (vtk_interval_ > 0) {
          const long to_vtk = std::lround((next_vtk_ - sim_.time()) / sim_.timeStep());
          if (to_vtk <= 0) {
            writeVtk();
            continue;
          }
          chunk = std::min(chunk, to_vtk);
        }
        sim_.run(chunk);
        done += chunk;
      }
    } catch (const BlowUp& e) {
      throw CouplingError(ErrorCode::SimulationFailed, e.what());
    } catch (const adapter::OutputError& e) {
      throw CouplingError(ErrorCode::Internal, std::string("builtin DEM VTK output: ") + e.what());
    }
    const double span = static_cast<double>(steps) * sim_.timeStep();
    for (const auto& [name, m] : meshes_) {
      auto mean = sim_.nodeImpulse(m);
      for (double& f : mean) f /= span;
      interval_mean_[m] = std::move(mean);
    }
  }

  adapter::RigidMotion rigidMotion(const std::string& geometry) override {
    const auto& mesh = sim_.mesh(meshOf(geometry));
    return {mesh.origin, mesh.velocity, mesh.t0};
  }

  void setRigidMotion(const std::string& geometry, const adapter::RigidMotion& motion) override {
    sim_.setMeshMotion(meshOf(geometry), motion.origin_m, motion.velocity_m_s, motion.t0_s);
  }

  void checkpoint(const std::filesystem::path& file) override {
    alive();
    adapter::PayloadWriter out;
    sim_.saveState(out);
    out.put(last_positions_time_);
    out.put(next_vtk_);
    out.put(static_cast<std::int64_t>(vtk_count_));
    out.put(static_cast<std::uint64_t>(interval_mean_.size()));
    for (const auto& [m, f] : interval_mean_) {
      out.put(static_cast<std::int64_t>(m));
      out.putVector(f);
    }
    adapter::writeCheckpointFile(file, kCheckpointKind, out.bytes());
  }

  // The file is validated completely (container, then every array against this simulation) before
  // anything is assigned: a refused checkpoint leaves the backend exactly as it was.
  void restore(const std::filesystem::path& file) override {
    alive();
    const std::string payload = adapter::readCheckpointFile(file, kCheckpointKind);
    adapter::PayloadReader in(payload, "checkpoint " + file.string());
    DemSimulation restored = sim_.withState(in);
    const auto last_positions_time = in.get<double>(), next_vtk = in.get<double>();
    const auto vtk_count = in.get<std::int64_t>();
    if (!std::isfinite(last_positions_time) || !std::isfinite(next_vtk) || vtk_count < 0)
      in.fail("output clock out of range");
    const auto count = in.get<std::uint64_t>();
    if (count > meshes_.size()) in.fail("more interval means than meshes");
    std::map<int, adapter::NodeArray> interval_mean;
    for (std::uint64_t k = 0; k < count; ++k) {
      const auto m = in.get<std::int64_t>();
      auto mean = in.getVector<double>();
      if (m < 0 || m >= restored.meshCount() || mean.size() != 3 * restored.mesh(static_cast<int>(m)).nodes.size())
        in.fail("an interval mean does not fit its mesh");
      interval_mean[static_cast<int>(m)] = std::move(mean);
    }
    in.finish();
    sim_ = std::move(restored);
    last_positions_time_ = last_positions_time;
    next_vtk_ = next_vtk;
    vtk_count_ = static_cast<long>(vtk_count);
    interval_mean_ = std::move(interval_mean);
    if (vtk_interval_ > 0) openVtkSeries(sim_.time());
  }

  void shutdown() override { closed_ = true; }

 private:
  void alive() const {
    if (closed_) throw CouplingError(ErrorCode::BadRequest, "builtin DEM: the simulation was shut down");
  }

  int meshOf(const std::string& geometry) const {
    alive();
    const auto it = meshes_.find(geometry);
    if (it == meshes_.end()) throw CouplingError(ErrorCode::UnknownGeometry, "builtin DEM: no geometry named '" + geometry + "'");
    return it->second;
  }

  std::filesystem::path vtkDirectory() const { return study_.output.directory / "vtk"; }

  // One collection per series (particles, each tool), continued from `resume_time_s` after a restore.
  // The directory is made by the first file written: a backend built for a run that never starts
  // (its output directory held by another run) leaves nothing there.
  void openVtkSeries(std::optional<double> resume_time_s) {
    vtk_series_.clear();
    vtk_series_.emplace("particles", adapter::VtkSeries(vtkDirectory() / "particles.pvd", resume_time_s));
    for (const auto& [name, m] : meshes_)
      vtk_series_.emplace("dem-" + name, adapter::VtkSeries(vtkDirectory() / ("dem-" + name + ".pvd"), resume_time_s));
  }

  // Particles and tools at the current time, named by the FEM step they begin (the FEM client's
  // tool files of the same instant carry the same number and time).
  void writeVtk() {
    std::filesystem::create_directories(vtkDirectory());
    char index[24];
    std::snprintf(index, sizeof(index), "_%06lld.vtp", static_cast<long long>(std::llround(sim_.time() / study_.fem.dt_s)));
    const std::string particles = std::string("particles") + index;
    sim_.writeParticlesVtk(vtkDirectory() / particles);
    vtk_series_.at("particles").add(sim_.time(), particles);
    for (const auto& [name, m] : meshes_) {
      const std::string file = "dem-" + name + index;
      sim_.writeMeshVtk(m, vtkDirectory() / file);
      vtk_series_.at("dem-" + name).add(sim_.time(), file);
    }
    ++vtk_count_;
    next_vtk_ += vtk_interval_;
  }

  study::Study study_;
  DemSimulation sim_;
  std::string soil_record_;  // adapter::soilRecordJson() of the soil it started from
  std::map<std::string, int> meshes_;
  std::map<int, adapter::NodeArray> interval_mean_;
  double last_positions_time_ = 0;
  double vtk_interval_ = 0, next_vtk_ = 0;
  long vtk_count_ = 0;
  std::map<std::string, adapter::VtkSeries> vtk_series_;
  bool closed_ = false;
};

}  // namespace

TriangleMesh toolMesh(const study::Tool& tool) {
  adapter::ToolSurface surface;
  try {
    surface = adapter::toolSurface(tool);
  } catch (const std::invalid_argument& e) {
    throw CouplingError(ErrorCode::Unsupported, std::string("builtin DEM: ") + e.what());
  }
  TriangleMesh mesh;
  mesh.name = tool.name;
  for (const auto& n : surface.nodes) mesh.rest_nodes.push_back({n[0], n[1], n[2]});
  mesh.nodes = mesh.rest_nodes;
  mesh.triangles = surface.triangles;
  return mesh;
}

namespace {

// `make` with the errors of the coupling API (backend.hpp).
template <class Make>
auto asCouplingErrors(Make&& make) {
  try {
    return make();
  } catch (const CouplingError&) {
    throw;
  } catch (const BlowUp& e) {
    throw CouplingError(ErrorCode::SimulationFailed, e.what());
  } catch (const std::exception& e) {
    throw CouplingError(ErrorCode::BadRequest, e.what());
  }
}

std::filesystem::path settledSoilOf(const study::Study& study, const DepositProgress& deposit_progress) {
  const auto file = adapter::settledSoilFile(study, adapter::defaultSoilDirectory());
  if (!std::filesystem::exists(file)) {
    if (study.soil.deposition_backend != capabilities().name)
      throw CouplingError(ErrorCode::BadRequest,
                          "builtin DEM: no settled soil " + file.string() + "; the study deposits it with " + study.soil.deposition_backend +
                              " (/soil/deposition/backend): run `demfem deposit` on the study first");
    adapter::depositOnce(file, [&] {
      DepositReport report;
      return depositSoil(study, study.soil.deposition_threads, report, deposit_progress);
    });
  }
  return file;
}

}  // namespace

std::filesystem::path ensureSettledSoil(const study::Study& study, const DepositProgress& deposit_progress) {
  return asCouplingErrors([&] { return settledSoilOf(study, deposit_progress); });
}

std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study, const DepositProgress& deposit_progress) {
  return asCouplingErrors([&]() -> std::unique_ptr<adapter::CouplingApi> {
    const auto file = settledSoilOf(study, deposit_progress);
    const adapter::SettledSoil soil = adapter::readSettledSoil(file, study);
    return std::make_unique<BuiltinBackend>(study, soil, adapter::soilRecordJson(soil, file, adapter::settledSoilChecksum(file)));
  });
}

}  // namespace demfem::builtin
