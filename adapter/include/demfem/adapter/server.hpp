// The DEM adapter server: serves any CouplingApi over the demfem protocol (docs/architecture.md sections 2-3,
// docs/protocol.md).
//
// Contract
// - handle() turns one request message into one reply message and never throws: a malformed,
//   oversized, wrong-version or out-of-order request, or a CouplingError/exception of the backend,
//   becomes an error reply ({"error":{"code":..,"message":..}}, codes of adapter::ErrorCode).
// - Session rules: the first request must be "hello" with protocol version 1 (else VersionMismatch
//   or BadRequest); "seq" must increase strictly; after "shutdown" (which calls the backend's
//   shutdown()) every request gets an error.
// - serve() answers requests until shutdown and returns; it throws CouplingError(PeerGone) when no
//   request arrives within the timeout (first_request_timeout before "hello", idle_timeout after),
//   after shutting the backend down, so a server whose client vanished ends with a clear message.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/protocol/transport.hpp"

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

namespace demfem::adapter {

struct ServeOptions {
  std::chrono::milliseconds first_request_timeout{std::chrono::minutes(10)};
  std::chrono::milliseconds idle_timeout{std::chrono::seconds(60)};
};

class Server {
 public:
  explicit Server(CouplingApi& api);

  protocol::Multipart handle(const protocol::Multipart& request) noexcept;
  bool shutdownDone() const { return shutdown_done_; }

  void serve(protocol::ServerSocket& socket, const ServeOptions& options);

 private:
  protocol::ReplyBody dispatch(const protocol::Request& request);

  CouplingApi& api_;
  bool hello_done_ = false;
  bool shutdown_done_ = false;
  std::uint64_t last_seq_ = 0;
};

}  // namespace demfem::adapter
