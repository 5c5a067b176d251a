// Private to the LIGGGHTS backend: the engine, one rank's part of the LIGGGHTS simulation of a
// study (engine.cpp, engine_setup.cpp). The leader/follower broadcast (leader_follower.hpp) replays
// its collective calls on every rank; the facade (backend.cpp) offers it as the coupling API. No
// LIGGGHTS or MPI header here: their types appear only as forward declarations
// (docs/liggghts-backend.md).
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/backends/liggghts/input_deck.hpp"

#include "session.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace LAMMPS_NS {
class FixMeshSurface;
}

namespace demfem::liggghts::detail {

using Vec3 = std::array<double, 3>;

class NodeArrayAccess;  // engine.cpp: access to a LIGGGHTS mesh's node array

// One tool as the engine holds it: its keypoint surface, its LIGGGHTS mesh and what was accumulated.
struct ToolState {
  ToolState();
  ToolState(ToolState&&) noexcept;
  ToolState& operator=(ToolState&&) noexcept;
  ~ToolState();

  std::string name;
  adapter::ToolSurface surface;
  LAMMPS_NS::FixMeshSurface* mesh_fix = nullptr;
  std::unique_ptr<NodeArrayAccess> node_access;
  int id_offset = 0;                 // LIGGGHTS triangle id of surface triangle 0
  adapter::RigidMotion motion;
  std::vector<double> deformation;   // n x 3, local frame: current keypoint - undeformed keypoint
  std::vector<double> force_sum;     // n x 3, sum over the steps of the current interval
  std::vector<double> force_last;    // n x 3, the last step
};

// A work directory name unique to this process, call and rank.
std::string uniqueWorkDirectoryName(int rank);

// One rank's part of the LIGGGHTS simulation of a study. Every method except time() and the
// accessors is collective: all ranks call it in the same order with the same arguments.
class Engine {
 public:
  // Builds the simulation (backend.hpp's construction contract) in a fresh work directory.
  Engine(const study::Study& study, const BackendOptions& options);
  ~Engine();
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  double timeStep() const { return dt_; }
  double time() const;  // s since the end of the set-up
  std::string version() const;
  std::size_t toolCount() const { return tools_.size(); }
  const ToolState& tool(std::size_t g) const { return tools_[g]; }

  // Runs `steps` DEM steps (0: refreshes derived data only; the last interval's forces stay).
  void simulate(long long steps);
  // Keypoint positions of tool g in its local frame, merged from the triangle copies of all ranks.
  adapter::NodeArray nodePositions(std::size_t g);
  // Force of the particles on the keypoints of tool g, summed over the ranks.
  adapter::NodeArray nodeForces(std::size_t g, adapter::ForceMode mode);
  // Total force on tool g from LIGGGHTS' own stress mesh (fix mesh/surface/stress), last step (N).
  Vec3 meshTotalForce(std::size_t g);
  void setNodePositions(std::size_t g, const adapter::NodeArray& xyz);
  void setRigidMotion(std::size_t g, const adapter::RigidMotion& motion);

  std::int64_t particleCount() const;
  SettledParticles particles() const;
  SoilOrigin soilOrigin() const { return {soil_file_, soil_deposited_}; }
  const std::string& soilRecord() const { return soil_record_; }

 private:
  void command(const std::string& line);

  // --- set-up (engine_setup.cpp) ---
  void build(const study::Study& study, const BackendOptions& options);
  void addTools(const study::Study& study);
  void placeSoil(const study::Study& study, const InputDeck& deck, const BackendOptions& options);
  void placeProbes(const study::Study& study, const InputDeck& deck, const BackendOptions& options);
  void installForceHook();
  void openMainInstance(const InputDeck& deck);
  void addSphere(int type, const Vec3& centre, double radius, double density);
  SettledParticles settledSoil(const study::Study& study, const InputDeck& deck, const BackendOptions& options);
  adapter::SettledSoil readOrDepositSoil(const study::Study& study, const InputDeck& deck);
  void depositAndWriteSoil(const study::Study& study, const InputDeck& deck, adapter::SettledSoil& soil);
  void checkMesh(std::size_t g);

  // --- the running simulation and the tool meshes' node access (engine.cpp) ---
  void release();
  void findMesh(std::size_t g);
  Vec3 keypoint(const ToolState& tool, std::size_t k) const;
  std::array<std::int32_t, 3> copyKeypoints(const ToolState& tool, int i) const;
  void moveCopies(ToolState& tool, const std::function<Vec3(std::size_t)>& displacement);
  static void afterForces(void* self, std::int64_t step, int nlocal, int* ids, double** x, double** fexternal);
  void accumulate(int nlocal, double** x, double** fexternal);
  void accumulateTool(ToolState& tool, int nlocal, double** x, double t);

  std::filesystem::path work_dir_;
  std::unique_ptr<Instance> instance_;
  LAMMPS_NS::LAMMPS* lmp_ = nullptr;  // instance_'s
  std::filesystem::path soil_file_;
  bool soil_deposited_ = false;
  std::string soil_record_;  // adapter::soilRecordJson() of the soil file (rank 0)
  std::vector<ToolState> tools_;
  double dt_ = 0;
  std::int64_t start_step_ = 0;
  long long accumulated_steps_ = 0;
  bool mesh_edited_ = true;
};

// The rigid offset of a motion at time t (m): origin + velocity (t - t0).
Vec3 rigidOffset(const adapter::RigidMotion& m, double t);

}  // namespace demfem::liggghts::detail
