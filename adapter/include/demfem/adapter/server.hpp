// The DEM adapter server: serves any CouplingApi over the demfem protocol (docs/architecture.md
// sections 2-3, docs/protocol.md; what was tried against it is in docs/reliability.md).
//
// Contract
// - handle() turns one request message from one connection into one reply message and never
//   throws: a malformed, oversized, wrong-version or out-of-order request, a request from a
//   connection that does not own the session, or a CouplingError/exception of the backend, becomes
//   an error reply ({"error":{"code":..,"message":..}}, codes of adapter::ErrorCode).
// - Sessions: a "hello" with protocol version 1 from any connection opens a session when none is
//   open; the connection (ZeroMQ routing id) owns it, and the hello reply carries a random session
//   token that every later request must repeat. Requests from other connections, or with another
//   token, get Busy and change nothing (not the session, its sequence numbers or its idle clock).
//   "seq" must increase strictly within the session, starting after the hello's seq. A hello from
//   the owner starts a fresh session. When the owner has sent nothing for
//   ServerOptions::idle_timeout the session ends and any connection may say hello.
// - "shutdown" calls the backend's shutdown() and ends the session; every later request gets an
//   error (the backend is gone).
// - simulate and advance: a duration above ServerOptions::max_simulate_s is refused (BadRequest) before the
//   backend sees it; the hello reply states the limit.
// - checkpoint/restore carry a checkpoint NAME (protocol::isCheckpointName), resolved in
//   ServerOptions::checkpoint_dir; without a directory both are refused (Unsupported). A failed
//   restore answers the same message whatever the cause (missing, unreadable or invalid file), so
//   a peer cannot probe which files exist; the cause goes to ServerOptions::log.
// - serve() tells the socket which connection owns the session (ServerSocket::setOwner), so that a
//   request larger than a hello from any other connection is dropped unread (answered BadRequest,
//   docs/protocol.md "Sessions") and the owner's connection survives the connection limits.
// - serve() answers requests until shutdown and returns; it throws CouplingError(PeerGone), after
//   shutting the backend down, when no session is open and no hello arrives within `hello_timeout`
//   of the start, or within the idle timeout of the end of the last session (its client may
//   reconnect meanwhile).
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/protocol/transport.hpp"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace demfem::adapter {

// Longest simulate call a server accepts unless configured: the study file's default
// coupling.max_simulate_s, study::kDefaultMaxSimulateS (the server tests hold the two together; this
// header does not include the study library, so that it installs without it).
inline constexpr double kDefaultMaxSimulateS = 1.0;

struct ServerOptions {
  std::filesystem::path checkpoint_dir;  // empty: no checkpoints
  double max_simulate_s = kDefaultMaxSimulateS;
  std::chrono::milliseconds idle_timeout{std::chrono::seconds(60)};
  std::function<void(const std::string&)> log;  // diagnostics not sent to peers; may be empty
};

class Server {
 public:
  using Clock = std::chrono::steady_clock;

  explicit Server(CouplingApi& api, ServerOptions options = {});

  protocol::Multipart handle(const protocol::PeerAddress& from, const protocol::Multipart& request,
                             Clock::time_point now = Clock::now()) noexcept;
  bool shutdownDone() const { return shutdown_done_; }
  // A session is open and its owner has not been silent for longer than the idle timeout.
  bool sessionOpen(Clock::time_point now) const;

  void serve(protocol::ServerSocket& socket, std::chrono::milliseconds hello_timeout);

 private:
  struct Session {
    protocol::PeerAddress owner;
    std::string token;
    std::uint64_t last_seq = 0;
    Clock::time_point last_seen;
  };

  protocol::ReplyBody dispatch(const protocol::PeerAddress& from, const protocol::Request& request,
                               Clock::time_point now);
  protocol::ReplyBody hello(const protocol::PeerAddress& from, const protocol::Request& request, Clock::time_point now);
  void checkOwner(const protocol::PeerAddress& from, const protocol::Request& request, Clock::time_point now);
  protocol::ReplyBody serveCall(const protocol::Request& request);
  void checkDuration(double duration_s) const;  // throws BadRequest above max_simulate_s
  std::filesystem::path checkpointPath(const std::string& name) const;
  bool endIdleSession(Clock::time_point now);  // true if it ended one
  void log(const std::string& text) const;

  CouplingApi& api_;
  ServerOptions options_;
  std::optional<Session> session_;
  bool shutdown_done_ = false;
};

}  // namespace demfem::adapter
