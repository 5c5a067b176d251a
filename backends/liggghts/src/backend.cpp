// The liggghts backend: LIGGGHTS-PUBLIC 3.8 in-process, one instance per MPI rank (backend.hpp).
// This file: the facade, the coupling API on rank 0 (it checks arguments, broadcasts each operation
// to the other ranks and runs it on its own engine). The engine (one rank's part of the
// simulation) is in engine.hpp, the leader/follower broadcast in leader_follower.hpp, the MPI
// session, the instance and the settled soil in session.hpp. LIGGGHTS and MPI headers stay in the
// .cpp files (pimpl): nothing of them leaks into our headers.
#include "demfem/backends/liggghts/backend.hpp"

#include "engine.hpp"
#include "leader_follower.hpp"

#include <cmath>
#include <filesystem>

namespace demfem::liggghts {

using namespace detail;

namespace {

using adapter::CouplingError;
using adapter::ErrorCode;
using adapter::ForceMode;
using adapter::NodeArray;
using adapter::RigidMotion;

void requireFinite(const std::vector<double>& values, const std::string& what) {
  for (std::size_t v = 0; v < values.size(); ++v)
    if (!std::isfinite(values[v]))
      throw CouplingError(ErrorCode::BadRequest, what + ": value " + std::to_string(v) + " is not finite");
}

// The coupling API on rank 0: checks arguments, broadcasts the operation, runs it locally.
class LiggghtsBackend final : public adapter::CouplingApi {
 public:
  LiggghtsBackend(const study::Study& study, const BackendOptions& options)
      : engine_(std::make_unique<Engine>(study, options)) {}
  ~LiggghtsBackend() override {
    try {
      shutdown();
    } catch (...) {  // a destructor must not throw; followers are released by the broadcast above
    }
  }

  adapter::BackendInfo info() override {
    auto& e = live();
    adapter::BackendInfo i;
    i.backend = "liggghts";
    i.version = e.version();
    i.dem_time_step_s = e.timeStep();
    i.soil_json = e.soilRecord();
    return i;
  }

  std::vector<adapter::GeometryInfo> geometries() override {
    auto& e = live();
    std::vector<adapter::GeometryInfo> list;
    for (std::size_t g = 0; g < e.toolCount(); ++g) {
      const auto& tool = e.tool(g);
      list.push_back({tool.name, static_cast<std::int32_t>(tool.surface.nodes.size()), tool.surface.triangles});
    }
    return list;
  }

  double time() override { return live().time(); }

  NodeArray nodePositions(const std::string& geometry) override {
    OpHeader h{Op::NodePositions, index(geometry), 0, 0, 0};
    std::vector<double> none;
    broadcast(h, none);
    return live().nodePositions(static_cast<std::size_t>(h.geometry));
  }

  NodeArray nodeForces(const std::string& geometry, ForceMode mode) override {
    OpHeader h{Op::NodeForces, index(geometry), static_cast<std::int32_t>(mode), 0, 0};
    std::vector<double> none;
    broadcast(h, none);
    return live().nodeForces(static_cast<std::size_t>(h.geometry), mode);
  }

  void setNodePositions(const std::string& geometry, const NodeArray& xyz) override {
    const std::int32_t g = index(geometry);
    const std::size_t expected = 3 * live().tool(static_cast<std::size_t>(g)).surface.nodes.size();
    if (xyz.size() != expected)
      throw CouplingError(ErrorCode::SizeMismatch, "setNodePositions(\"" + geometry + "\"): " +
                                                       std::to_string(xyz.size()) + " values, expected " +
                                                       std::to_string(expected) + " (n x 3)");
    requireFinite(xyz, "setNodePositions(\"" + geometry + "\")");
    OpHeader h{Op::SetNodePositions, g, 0, 0, static_cast<std::int64_t>(xyz.size())};
    std::vector<double> payload = xyz;
    broadcast(h, payload);
    live().setNodePositions(static_cast<std::size_t>(g), xyz);
  }

  void simulate(double duration_s) override {
    auto& e = live();
    if (!(duration_s >= 0) || !std::isfinite(duration_s))
      throw CouplingError(ErrorCode::BadRequest, "simulate: duration must be finite and >= 0 s, got " +
                                                     std::to_string(duration_s));
    OpHeader h{Op::Simulate, 0, 0, std::llround(duration_s / e.timeStep()), 0};
    std::vector<double> none;
    broadcast(h, none);
    e.simulate(h.steps);
    for (std::size_t g = 0; g < e.toolCount(); ++g)
      for (double v : e.tool(g).force_last)
        if (!std::isfinite(v))
          throw CouplingError(ErrorCode::SimulationFailed, "LIGGGHTS produced a non-finite force on tool \"" +
                                                               e.tool(g).name + "\"; reduce the DEM time step");
  }

  RigidMotion rigidMotion(const std::string& geometry) override {
    return live().tool(static_cast<std::size_t>(index(geometry))).motion;
  }

  void setRigidMotion(const std::string& geometry, const RigidMotion& motion) override {
    std::vector<double> payload = motionPayload(motion);
    requireFinite(payload, "setRigidMotion(\"" + geometry + "\")");
    OpHeader h{Op::SetRigidMotion, index(geometry), 0, 0, static_cast<std::int64_t>(payload.size())};
    broadcast(h, payload);
    live().setRigidMotion(static_cast<std::size_t>(h.geometry), motion);
  }

  void checkpoint(const std::filesystem::path&) override {
    throw CouplingError(ErrorCode::Unsupported, "the liggghts backend does not offer checkpoints");
  }
  void restore(const std::filesystem::path&) override {
    throw CouplingError(ErrorCode::Unsupported, "the liggghts backend does not offer checkpoints");
  }

  std::array<double, 3> meshTotalForce(const std::string& geometry) {
    return live().meshTotalForce(static_cast<std::size_t>(index(geometry)));
  }

  std::int64_t particleCount() { return live().particleCount(); }
  SoilOrigin soilOrigin() { return live().soilOrigin(); }
  std::vector<std::array<double, 4>> particles() {
    if (multipleRanks())
      throw CouplingError(ErrorCode::Unsupported, "particle positions are only offered on a single MPI rank");
    const SettledParticles all = live().particles();
    std::vector<std::array<double, 4>> xyzr;
    for (std::size_t i = 0; i < all.size(); i += kParticleValues) xyzr.push_back({all[i], all[i + 1], all[i + 2], all[i + 3]});
    return xyzr;
  }

  void shutdown() override {
    if (!engine_) return;
    OpHeader h{Op::Shutdown, 0, 0, 0, 0};
    std::vector<double> none;
    broadcast(h, none);
    engine_.reset();
  }

 private:
  Engine& live() {
    if (!engine_) throw CouplingError(ErrorCode::BadRequest, "the liggghts backend was shut down");
    return *engine_;
  }

  std::int32_t index(const std::string& geometry) {
    auto& e = live();
    for (std::size_t g = 0; g < e.toolCount(); ++g)
      if (e.tool(g).name == geometry) return static_cast<std::int32_t>(g);
    throw CouplingError(ErrorCode::UnknownGeometry, "unknown geometry \"" + geometry + "\"");
  }

  std::unique_ptr<Engine> engine_;
};

}  // namespace

std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study) { return makeBackend(study, {}); }

std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study, const BackendOptions& options) {
  ensureMpi();
  return std::make_unique<LiggghtsBackend>(study, options);
}

namespace {

// The backend behind `backend` if this factory made it; `caller` names the function in the error.
LiggghtsBackend& liggghtsBackend(adapter::CouplingApi& backend, const char* caller) {
  auto* liggghts = dynamic_cast<LiggghtsBackend*>(&backend);
  if (!liggghts) throw CouplingError(ErrorCode::BadRequest, std::string(caller) + ": not a liggghts backend");
  return *liggghts;
}

}  // namespace

std::array<double, 3> meshTotalForce(adapter::CouplingApi& backend, const std::string& geometry) {
  return liggghtsBackend(backend, "meshTotalForce").meshTotalForce(geometry);
}

std::int64_t particleCount(adapter::CouplingApi& backend) {
  return liggghtsBackend(backend, "particleCount").particleCount();
}

SoilOrigin soilOrigin(adapter::CouplingApi& backend) { return liggghtsBackend(backend, "soilOrigin").soilOrigin(); }

std::vector<std::array<double, 4>> particles(adapter::CouplingApi& backend) {
  return liggghtsBackend(backend, "particles").particles();
}

adapter::SettledSoil depositSoil(const study::Study& study) {
  ensureMpi();
  const auto work_dir = std::filesystem::temp_directory_path() / uniqueWorkDirectoryName(worldRank());
  std::filesystem::create_directories(work_dir);
  struct Cleanup {
    std::filesystem::path dir;
    ~Cleanup() {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  } cleanup{work_dir};
  return depositInInstance(study, translateStudy(study, work_dir), work_dir);
}

bool isLeaderRank() {
  ensureMpi();
  return worldRank() == 0;
}

}  // namespace demfem::liggghts
