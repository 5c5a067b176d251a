// Private to the LIGGGHTS backend: the leader/follower broadcast (leader_follower.cpp). Rank 0 (the
// leader, backend.cpp's facade) broadcasts each collective engine operation before it runs it; the
// other ranks (followLeader(), backend.hpp) receive and replay it on their engine (engine.hpp), so
// that every rank calls the engine in the same order with the same arguments. No MPI header here.
#pragma once

#include "engine.hpp"

#include <cstdint>
#include <vector>

namespace demfem::liggghts::detail {

enum class Op : std::int32_t { Simulate = 1, NodePositions, NodeForces, SetNodePositions, SetRigidMotion, Shutdown };

struct OpHeader {
  Op op = Op::Shutdown;
  std::int32_t geometry = 0;
  std::int32_t force_mode = 0;
  std::int64_t steps = 0;
  std::int64_t payload = 0;  // number of doubles broadcast after the header
};

// True when the process runs on more than one MPI rank.
bool multipleRanks();

// Broadcast from rank 0 of a header and its payload (resized on the other ranks; a no-op on a
// single rank). Collective.
void broadcast(OpHeader& header, std::vector<double>& payload);

// A rigid motion as a broadcast payload (7 doubles: origin, velocity, t0) and back.
std::vector<double> motionPayload(const adapter::RigidMotion& m);
adapter::RigidMotion motionFromPayload(const std::vector<double>& p);

}  // namespace demfem::liggghts::detail
