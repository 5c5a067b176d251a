// demfem wire protocol, version 1: the messages exchanged between a FEM client and a DEM adapter
// server (docs/architecture.md section 3; written down for other languages in docs/protocol.md).
//
// Contract
// - One request gets exactly one reply: the reply for its operation, or an ErrorReply.
// - Units are SI (m, s, N); node arrays are n x 3 row-major in the geometry's local frame, exactly
//   as in adapter/coupling_api.hpp. This layer only carries them: it checks sizes and finiteness,
//   never physics.
// - Scalars (sequence number, durations, times, counts) travel in the JSON header; arrays travel in
//   binary frames (codec.hpp), never as JSON numbers.
// - Error codes on the wire are the numeric values of WireError; adapter::ErrorCode uses the same
//   values (checked at compile time in the adapter).
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

namespace demfem::protocol {

inline constexpr std::int32_t kProtocolVersion = 1;

enum class WireError : std::int32_t {
  BadRequest = 1,
  UnknownGeometry = 2,
  SizeMismatch = 3,
  VersionMismatch = 4,
  SimulationFailed = 5,
  Timeout = 6,
  PeerGone = 7,
  Unsupported = 8,
  Internal = 9,
  Busy = 10,  // another client owns the server's session
};
inline constexpr std::int32_t kLastWireError = 10;

// A message that cannot be decoded or a transport failure. `code` says which (BadRequest for a
// malformed message, VersionMismatch, Timeout, PeerGone, ...).
class ProtocolError : public std::runtime_error {
 public:
  ProtocolError(WireError code, const std::string& message)
      : std::runtime_error(message), code_(code) {}
  WireError code() const { return code_; }

 private:
  WireError code_;
};

enum class ForceMode { IntervalMean, Instantaneous };

// x_bin = origin + x_local + velocity * (t - t0), SI units, bin frame (adapter::RigidMotion).
struct RigidMotionData {
  std::array<double, 3> origin_m{0, 0, 0};
  std::array<double, 3> velocity_m_s{0, 0, 0};
  double t0_s = 0;
  bool operator==(const RigidMotionData&) const = default;
};

// ---- requests (client -> server) ----
struct Hello {  // must be the first request; the server answers HelloReply or VersionMismatch
  std::int32_t protocol_version = kProtocolVersion;
  std::string client;  // free text identifying the client, for logs
  bool operator==(const Hello&) const = default;
};
struct ListGeometries { bool operator==(const ListGeometries&) const = default; };
struct GetTime { bool operator==(const GetTime&) const = default; };
struct GetNodePositions {
  std::string geometry;
  bool operator==(const GetNodePositions&) const = default;
};
struct GetNodeForces {
  std::string geometry;
  ForceMode mode = ForceMode::IntervalMean;
  bool operator==(const GetNodeForces&) const = default;
};
struct SetNodePositions {
  std::string geometry;
  std::vector<double> xyz;  // n x 3, m
  bool operator==(const SetNodePositions&) const = default;
};
struct Simulate {
  double duration_s = 0;  // >= 0
  bool operator==(const Simulate&) const = default;
};
// One coupling cycle in one round trip: set_node_positions (unless xyz is empty: a rigid tool),
// simulate, get_node_forces of the interval.
struct Advance {
  std::string geometry;
  std::vector<double> xyz;  // n x 3, m; empty: positions unchanged
  double duration_s = 0;    // >= 0
  ForceMode mode = ForceMode::IntervalMean;
  bool operator==(const Advance&) const = default;
};
struct GetRigidMotion {
  std::string geometry;
  bool operator==(const GetRigidMotion&) const = default;
};
struct SetRigidMotion {
  std::string geometry;
  RigidMotionData motion;
  bool operator==(const SetRigidMotion&) const = default;
};
// A checkpoint is named, not located: `name` is a file name (see isCheckpointName()) that the
// server resolves in its own checkpoint directory.
struct Checkpoint {
  std::string name;
  bool operator==(const Checkpoint&) const = default;
};
struct Restore {
  std::string name;
  bool operator==(const Restore&) const = default;
};
struct Shutdown { bool operator==(const Shutdown&) const = default; };

using RequestBody = std::variant<Hello, ListGeometries, GetTime, GetNodePositions, GetNodeForces,
                                 SetNodePositions, Simulate, Advance, GetRigidMotion, SetRigidMotion,
                                 Checkpoint, Restore, Shutdown>;

struct Request {
  Request(std::uint64_t seq_ = 0, RequestBody body_ = {}, std::string session_ = {})
      : seq(seq_), body(std::move(body_)), session(std::move(session_)) {}
  std::uint64_t seq;    // chosen by the client, strictly increasing within a session; echoed
  RequestBody body;
  std::string session;  // the token of the hello reply (empty in hello, and for servers without one)
  bool operator==(const Request&) const = default;
};

// ---- replies (server -> client) ----
struct HelloReply {
  HelloReply(std::int32_t protocol_version_ = kProtocolVersion, std::string backend_ = {},
             std::string backend_version_ = {}, double dem_time_step_s_ = 0, std::string session_ = {},
             double max_simulate_s_ = 0)
      : protocol_version(protocol_version_), backend(std::move(backend_)), backend_version(std::move(backend_version_)),
        dem_time_step_s(dem_time_step_s_), session(std::move(session_)), max_simulate_s(max_simulate_s_) {}
  std::int32_t protocol_version;
  std::string backend;          // "builtin", "liggghts", "harmonic", ...
  std::string backend_version;
  double dem_time_step_s;
  std::string session;          // token the client sends with every later request ("" = none)
  double max_simulate_s;        // longest simulate duration the server accepts (0 = not stated)
  // Optional header field "soil": a JSON object describing the settled soil the DEM started from
  // (figures of its deposition); kept here as that object's JSON text, "" when absent.
  std::string soil_json;
  // Optional header field "advance": true when the server answers `advance` (a server written
  // before it, or without it, leaves it out and the client uses the three calls instead).
  bool advance = false;
  bool operator==(const HelloReply&) const = default;
};
struct GeometryEntry {
  std::string name;
  std::int32_t node_count = 0;
  std::vector<std::array<std::int32_t, 3>> triangles;  // node ids, outward normals
  bool operator==(const GeometryEntry&) const = default;
};
struct GeometriesReply {
  std::vector<GeometryEntry> geometries;
  bool operator==(const GeometriesReply&) const = default;
};
struct TimeReply {  // answers GetTime and Simulate (the time reached)
  double time_s = 0;
  bool operator==(const TimeReply&) const = default;
};
struct AdvanceReply {  // answers Advance: the time reached and the interval's node forces (N)
  double time_s = 0;
  std::string geometry;
  std::vector<double> forces;
  bool operator==(const AdvanceReply&) const = default;
};
struct NodeArrayReply {  // answers GetNodePositions (m) and GetNodeForces (N)
  std::string geometry;
  std::vector<double> xyz;
  bool operator==(const NodeArrayReply&) const = default;
};
struct RigidMotionReply {
  RigidMotionData motion;
  bool operator==(const RigidMotionReply&) const = default;
};
struct Ack { bool operator==(const Ack&) const = default; };  // SetNodePositions, SetRigidMotion, Checkpoint, Restore, Shutdown
struct ErrorReply {
  WireError code = WireError::Internal;
  std::string message;
  bool operator==(const ErrorReply&) const = default;
};

using ReplyBody = std::variant<HelloReply, GeometriesReply, TimeReply, AdvanceReply, NodeArrayReply,
                               RigidMotionReply, Ack, ErrorReply>;

struct Reply {
  std::uint64_t seq = 0;  // the request's seq (0 if the request was too broken to read it)
  std::string op;         // the request's op name ("error" if unreadable)
  ReplyBody body;
  bool operator==(const Reply&) const = default;
};

// Wire name of a request ("hello", "get_node_forces", ...).
std::string opName(const RequestBody& body);

// Checkpoint names: 1 to 128 characters of [A-Za-z0-9._-], not starting with '.' (so never "..",
// a hidden file or a path).
inline constexpr std::size_t kMaxCheckpointNameBytes = 128;
bool isCheckpointName(const std::string& name);

}  // namespace demfem::protocol
