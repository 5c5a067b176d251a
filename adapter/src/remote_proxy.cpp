#include "demfem/adapter/remote_proxy.hpp"

#include "wire_conversions.hpp"

#include <cmath>

namespace demfem::adapter {

namespace p = protocol;

namespace {

template <class T>
T expect(p::ReplyBody&& body, const std::string& endpoint, const char* op) {
  if (auto* value = std::get_if<T>(&body)) return std::move(*value);
  throw CouplingError(ErrorCode::BadRequest, "DEM server at " + endpoint + " answered '" + op + "' with the wrong reply type");
}

}  // namespace

RemoteProxy::RemoteProxy(const RemoteOptions& options, protocol::Context* context) : endpoint_(options.endpoint) {
  if (!context) {
    own_context_ = std::make_unique<protocol::Context>();
    context = own_context_.get();
  }
  socket_ = std::make_unique<p::ClientSocket>(*context, options.endpoint, options.timeout, options.security);
  const auto hello = expect<p::HelloReply>(call(p::Hello{p::kProtocolVersion, options.client_name}), endpoint_, "hello");
  if (hello.protocol_version != p::kProtocolVersion)
    throw CouplingError(ErrorCode::VersionMismatch, "DEM server at " + endpoint_ + " speaks protocol version " +
                                                        std::to_string(hello.protocol_version) + ", this client " +
                                                        std::to_string(p::kProtocolVersion));
  info_ = {hello.backend, hello.backend_version, hello.protocol_version, hello.dem_time_step_s, hello.soil_json};
  session_ = hello.session;
  server_advances_ = hello.advance;
}

RemoteProxy::~RemoteProxy() = default;

p::ReplyBody RemoteProxy::call(p::RequestBody body, const std::function<void()>& meanwhile) {
  if (shut_down_) throw CouplingError(ErrorCode::BadRequest, "remote DEM backend at " + endpoint_ + " was shut down");
  const p::Request request{++seq_, std::move(body), session_};
  const std::string op = p::opName(request.body);
  p::Reply reply;
  try {
    reply = p::decodeReply(socket_->request(p::encode(request), meanwhile));
  } catch (const p::ProtocolError& e) {
    throw CouplingError(wire::toApi(e.code()), "'" + op + "' to DEM server " + endpoint_ + ": " + e.what());
  }
  if (auto* error = std::get_if<p::ErrorReply>(&reply.body))
    throw CouplingError(wire::toApi(error->code), "DEM server " + endpoint_ + " refused '" + op + "': " + error->message);
  if (reply.seq != request.seq || reply.op != op)
    throw CouplingError(ErrorCode::BadRequest, "DEM server " + endpoint_ + " answered seq " + std::to_string(reply.seq) +
                                                   " '" + reply.op + "' to request seq " + std::to_string(request.seq) +
                                                   " '" + op + "'");
  return std::move(reply.body);
}

std::vector<GeometryInfo> RemoteProxy::geometries() {
  auto reply = expect<p::GeometriesReply>(call(p::ListGeometries{}), endpoint_, "list_geometries");
  std::vector<GeometryInfo> list;
  for (auto& g : reply.geometries) list.push_back({g.name, g.node_count, std::move(g.triangles)});
  return list;
}

double RemoteProxy::time() { return expect<p::TimeReply>(call(p::GetTime{}), endpoint_, "get_time").time_s; }

NodeArray RemoteProxy::nodePositions(const std::string& geometry) {
  return expect<p::NodeArrayReply>(call(p::GetNodePositions{geometry}), endpoint_, "get_node_positions").xyz;
}

NodeArray RemoteProxy::nodeForces(const std::string& geometry, ForceMode mode) {
  return expect<p::NodeArrayReply>(call(p::GetNodeForces{geometry, wire::toWire(mode)}), endpoint_, "get_node_forces").xyz;
}

void RemoteProxy::setNodePositions(const std::string& geometry, const NodeArray& xyz) {
  if (xyz.size() % 3 != 0)
    throw CouplingError(ErrorCode::SizeMismatch, "setNodePositions('" + geometry + "'): array size " +
                                                     std::to_string(xyz.size()) + " is not n x 3");
  expect<p::Ack>(call(p::SetNodePositions{geometry, xyz}), endpoint_, "set_node_positions");
}

namespace {

void checkDuration(double duration_s) {
  if (!(duration_s >= 0) || !std::isfinite(duration_s))
    throw CouplingError(ErrorCode::BadRequest, "simulate(" + std::to_string(duration_s) + "): duration must be finite and >= 0");
}

}  // namespace

void RemoteProxy::simulate(double duration_s) {
  checkDuration(duration_s);
  expect<p::TimeReply>(call(p::Simulate{duration_s}), endpoint_, "simulate");
}

NodeArray RemoteProxy::advance(const std::string& geometry, const NodeArray& xyz, double duration_s, ForceMode mode,
                               const std::function<void()>& work) {
  checkDuration(duration_s);
  if (xyz.size() % 3 != 0)
    throw CouplingError(ErrorCode::SizeMismatch, "advance('" + geometry + "'): array size " + std::to_string(xyz.size()) +
                                                     " is not n x 3");
  if (server_advances_)
    return expect<p::AdvanceReply>(call(p::Advance{geometry, xyz, duration_s, wire::toWire(mode)}, work), endpoint_, "advance")
        .forces;
  if (!xyz.empty()) setNodePositions(geometry, xyz);
  expect<p::TimeReply>(call(p::Simulate{duration_s}, work), endpoint_, "simulate");
  return nodeForces(geometry, mode);
}

RigidMotion RemoteProxy::rigidMotion(const std::string& geometry) {
  return wire::toApi(expect<p::RigidMotionReply>(call(p::GetRigidMotion{geometry}), endpoint_, "get_rigid_motion").motion);
}

void RemoteProxy::setRigidMotion(const std::string& geometry, const RigidMotion& motion) {
  expect<p::Ack>(call(p::SetRigidMotion{geometry, wire::toWire(motion)}), endpoint_, "set_rigid_motion");
}

namespace {

std::string checkpointName(const std::filesystem::path& file, const std::string& endpoint) {
  if (!p::isCheckpointName(file.string()))
    throw CouplingError(ErrorCode::BadRequest,
                        "checkpoint '" + file.string() + "' for the DEM server " + endpoint +
                            ": remote checkpoints are named, not located (letters, digits, '.', '_', '-'; no "
                            "directory); the server keeps them in its --checkpoint-dir");
  return file.string();
}

}  // namespace

void RemoteProxy::checkpoint(const std::filesystem::path& file) {
  expect<p::Ack>(call(p::Checkpoint{checkpointName(file, endpoint_)}), endpoint_, "checkpoint");
}

void RemoteProxy::restore(const std::filesystem::path& file) {
  expect<p::Ack>(call(p::Restore{checkpointName(file, endpoint_)}), endpoint_, "restore");
}

void RemoteProxy::shutdown() {
  if (shut_down_) return;
  try {
    call(p::Shutdown{});
  } catch (const CouplingError& e) {
    if (e.code() != ErrorCode::Timeout && e.code() != ErrorCode::PeerGone) {
      shut_down_ = true;
      throw;
    }
  }
  shut_down_ = true;
}

}  // namespace demfem::adapter
