// The remote proxy: the coupling API (coupling_api.hpp) over the demfem protocol, so that client
// code cannot tell a DEM backend in another process (or host) from a local one.
//
// Contract
// - The constructor connects and performs the "hello" handshake: it throws CouplingError
//   (VersionMismatch) if the server speaks another protocol version, (Timeout/PeerGone) if the
//   server does not answer within `timeout` or refuses the CurveZMQ key.
// - Every call is one request/reply; errors of the server come back as CouplingError with the
//   server's code and message (prefixed with the endpoint). Timeouts throw CouplingError(Timeout)
//   with a message saying the DEM server is gone; the proxy is then unusable except shutdown().
// - info() is the handshake's answer (cached). shutdown() asks the server to shut its backend down;
//   it is idempotent and does not throw after a transport failure (the peer is gone anyway).
// - Checkpoint/restore take a checkpoint NAME (protocol::isCheckpointName, e.g. "dem_25.ckpt"),
//   not a path: the server keeps its checkpoints in its own directory. A path is refused here
//   (BadRequest) before anything is sent.
// - Every request after the handshake carries the session token of the hello reply.
// - advance() is one `advance` request when the server's hello reply offers it, else
//   set_node_positions, simulate (with the client's work done while it runs) and get_node_forces.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/protocol/transport.hpp"

#include <chrono>
#include <memory>
#include <optional>
#include <string>

namespace demfem::adapter {

struct RemoteOptions {
  std::string endpoint;                                // tcp://HOST:PORT, ipc://PATH, inproc://NAME
  std::chrono::milliseconds timeout{std::chrono::seconds(30)};
  std::optional<protocol::ClientSecurity> security;    // CurveZMQ keys
  std::string client_name = "demfem";
};

class RemoteProxy final : public CouplingApi {
 public:
  // `context`: a transport context to share (needed for inproc://); nullptr = own context.
  explicit RemoteProxy(const RemoteOptions& options, protocol::Context* context = nullptr);
  ~RemoteProxy() override;

  BackendInfo info() override { return info_; }
  std::vector<GeometryInfo> geometries() override;
  double time() override;
  NodeArray nodePositions(const std::string& geometry) override;
  NodeArray nodeForces(const std::string& geometry, ForceMode mode = ForceMode::IntervalMean) override;
  void setNodePositions(const std::string& geometry, const NodeArray& xyz) override;
  void simulate(double duration_s) override;
  NodeArray advance(const std::string& geometry, const NodeArray& xyz, double duration_s, ForceMode mode,
                    const std::function<void()>& work) override;
  RigidMotion rigidMotion(const std::string& geometry) override;
  void setRigidMotion(const std::string& geometry, const RigidMotion& motion) override;
  void checkpoint(const std::filesystem::path& file) override;
  void restore(const std::filesystem::path& file) override;
  void shutdown() override;

 private:
  protocol::ReplyBody call(protocol::RequestBody body, const std::function<void()>& meanwhile = {});

  std::unique_ptr<protocol::Context> own_context_;
  std::unique_ptr<protocol::ClientSocket> socket_;
  std::string endpoint_;
  std::uint64_t seq_ = 0;
  std::string session_;
  BackendInfo info_;
  bool server_advances_ = false;  // the hello reply said the server answers `advance`
  bool shut_down_ = false;
};

}  // namespace demfem::adapter
