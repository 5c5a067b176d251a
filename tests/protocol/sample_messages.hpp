// One sample of every protocol message (requests and replies), for the codec and fuzz tests.
#pragma once

#include "demfem/protocol/codec.hpp"

#include <vector>

namespace demfem::protocol::samples {

inline std::vector<Request> requests() {
  const std::vector<double> xyz{0.0, 0.1, -0.0015, 0.005, 0.1, 0.0015, 1e-300, -2.5e7, 3.0};
  return {
      {1, Hello{kProtocolVersion, "demfem-fem test"}},
      {2, ListGeometries{}},
      {3, GetTime{}},
      {4, GetNodePositions{"tool"}},
      {5, GetNodeForces{"tool", ForceMode::IntervalMean}},
      {6, GetNodeForces{"tool", ForceMode::Instantaneous}},
      {7, SetNodePositions{"tool", xyz}},
      {8, Simulate{1e-3}},
      {9, Simulate{0.0}},
      {10, GetRigidMotion{"tool"}},
      {11, SetRigidMotion{"tool", {{0.1, 0.085, -0.2}, {0.0, -0.05, 0.03119}, 0.25}}},
      {12, Checkpoint{"run.ckpt"}},
      {13, Restore{"run.ckpt"}},
      {14, Shutdown{}},
      {~0ull, GetNodePositions{"unicode \xc3\xa9 name"}},
      {15, GetTime{}, "0123456789abcdef0123456789abcdef"},
      {16, Advance{"tool", xyz, 1e-3, ForceMode::IntervalMean}},
      {17, Advance{"tool", {}, 0.0, ForceMode::Instantaneous}},
  };
}

inline std::vector<Reply> replies() {
  return {
      {1, "hello", HelloReply{kProtocolVersion, "harmonic", "analytic-1", 1e-5}},
      {1, "hello", HelloReply{kProtocolVersion, "builtin", "0.1", 2.1e-5, "0123456789abcdef0123456789abcdef", 1.0}},
      {1, "hello", [] {
         HelloReply r{kProtocolVersion, "builtin", "0.1", 9e-5};
         r.soil_json = R"({"particles":1455,"settled":true})";
         return r;
       }()},
      {1, "hello", [] {
         HelloReply r{kProtocolVersion, "builtin", "0.1", 9e-5};
         r.advance = true;
         return r;
       }()},
      {12, "checkpoint", ErrorReply{WireError::Busy, "busy: this server is serving another client"}},
      {2, "list_geometries",
       GeometriesReply{{{"tool", 4, {{0, 1, 2}, {0, 2, 3}}}, {"empty", 0, {}}}}},
      {3, "get_time", TimeReply{0.123456789012345678}},
      {8, "simulate", TimeReply{1e-3}},
      {4, "get_node_positions", NodeArrayReply{"tool", {0, 0.1, 0.2, 0.3, 0.4, 0.5}}},
      {5, "get_node_forces", NodeArrayReply{"tool", {-1.5, 2.25, 1e-20}}},
      {16, "advance", AdvanceReply{2.5e-3, "tool", {-1.5, 2.25, 1e-20, 0, 0, 3}}},
      {17, "advance", AdvanceReply{0, "tool", {}}},
      {10, "get_rigid_motion", RigidMotionReply{{{1, 2, 3}, {4, 5, 6}, 7}}},
      {7, "set_node_positions", Ack{}},
      {14, "shutdown", Ack{}},
      {9, "simulate", ErrorReply{WireError::SimulationFailed, "particle 17 left the bin"}},
      {0, "error", ErrorReply{WireError::BadRequest, "frame 0 is not valid JSON"}},
  };
}

}  // namespace demfem::protocol::samples
