// The leader/follower broadcast (leader_follower.hpp) and the followers' loop (followLeader(),
// backend.hpp).
#include "leader_follower.hpp"

#include <mpi.h>

namespace demfem::liggghts {

using namespace detail;

namespace detail {

bool multipleRanks() {
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return size > 1;
}

void broadcast(OpHeader& header, std::vector<double>& payload) {
  if (!multipleRanks()) return;
  MPI_Bcast(&header, sizeof(OpHeader), MPI_BYTE, 0, MPI_COMM_WORLD);
  payload.resize(static_cast<std::size_t>(header.payload));
  if (header.payload > 0) MPI_Bcast(payload.data(), static_cast<int>(header.payload), MPI_DOUBLE, 0, MPI_COMM_WORLD);
}

std::vector<double> motionPayload(const adapter::RigidMotion& m) {
  return {m.origin_m[0], m.origin_m[1], m.origin_m[2], m.velocity_m_s[0], m.velocity_m_s[1], m.velocity_m_s[2], m.t0_s};
}

adapter::RigidMotion motionFromPayload(const std::vector<double>& p) {
  adapter::RigidMotion m;
  m.origin_m = {p[0], p[1], p[2]};
  m.velocity_m_s = {p[3], p[4], p[5]};
  m.t0_s = p[6];
  return m;
}

}  // namespace detail

namespace {

// Executes one broadcast operation on this rank's engine.
void execute(Engine& engine, const OpHeader& header, const std::vector<double>& payload) {
  const auto g = static_cast<std::size_t>(header.geometry);
  switch (header.op) {
    case Op::Simulate: engine.simulate(header.steps); break;
    case Op::NodePositions: engine.nodePositions(g); break;
    case Op::NodeForces: engine.nodeForces(g, static_cast<adapter::ForceMode>(header.force_mode)); break;
    case Op::SetNodePositions: engine.setNodePositions(g, payload); break;
    case Op::SetRigidMotion: engine.setRigidMotion(g, motionFromPayload(payload)); break;
    case Op::Shutdown: break;
  }
}

}  // namespace

void followLeader(const study::Study& study) { followLeader(study, {}); }

void followLeader(const study::Study& study, const BackendOptions& options) {
  ensureMpi();
  Engine engine(study, options);
  while (true) {
    OpHeader header;
    std::vector<double> payload;
    broadcast(header, payload);
    if (header.op == Op::Shutdown) return;
    execute(engine, header, payload);
  }
}

}  // namespace demfem::liggghts
