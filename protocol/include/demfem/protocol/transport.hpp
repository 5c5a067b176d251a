// ZeroMQ transport of the demfem protocol: a ROUTER server socket and a REQ client socket carrying
// the multipart messages of codec.hpp, over inproc://, ipc:// or tcp://.
//
// Contract
// - Timeouts everywhere: ClientSocket::request() throws ProtocolError(Timeout) when no reply arrives
//   within the timeout (the message says the peer is gone or refused the client); the socket is then
//   unusable (REQ state) and every later request throws PeerGone; a signal interrupting the wait
//   throws ProtocolError(Internal) saying so. ServerSocket::receive() returns
//   nothing after its timeout, so a server can notice a vanished client.
// - The server socket is a ROUTER: every request arrives with the routing id ZeroMQ gave the
//   connection it came on (PeerAddress), and the reply goes back to that connection only. Several
//   clients may be connected; which one the server serves is the server's business (adapter/server.hpp).
// - ipc:// endpoints: ZeroMQ unlinks the path before binding, so checkBindEndpoint() refuses an ipc
//   path that exists and is not a socket (binding must never delete a file).
// - Loopback by default: a server refuses to bind tcp:// to a non-loopback address unless CurveZMQ
//   keys are given (then clients must authenticate).
// - CurveZMQ key directory (made by writeCurveKeyDirectory(), keys from zmq_curve_keypair, Z85 text
//   one key per file): server.pub, server.secret, client.pub, client.secret. The server needs
//   server.secret and client.pub (the only client key it accepts, checked by a ZAP handler); the
//   client needs server.pub, client.pub and client.secret. A client with another key is refused:
//   its request() throws ProtocolError(PeerGone) naming the refusal.
// - A server that closes the connection (it stopped or crashed) makes the pending or next request()
//   throw ProtocolError(PeerGone) at once instead of waiting for the timeout.
// - Frames above kMaxFrameBytes are dropped by ZeroMQ (ZMQ_MAXMSGSIZE) before they reach the codec.
#pragma once

#include "demfem/protocol/codec.hpp"

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace demfem::protocol {

class ServerSocket;
class ClientSocket;

// The ZeroMQ context the sockets of one process share (an inproc:// endpoint reaches only the
// sockets of its own context). No ZeroMQ type appears in this header: the transport is private to
// transport.cpp, so code using the protocol needs no ZeroMQ headers.
class Context {
 public:
  Context();
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

 private:
  friend class ServerSocket;
  friend class ClientSocket;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct CurveKeyPair {
  std::string public_key;  // Z85, 40 characters
  std::string secret_key;
};

struct ServerSecurity {
  CurveKeyPair server;
  std::string authorized_client_key;  // Z85 public key of the one client allowed in
};

struct ClientSecurity {
  std::string server_public_key;
  CurveKeyPair client;
};

// Creates `dir` (if needed) with fresh server and client key pairs; secret files get mode 0600.
void writeCurveKeyDirectory(const std::filesystem::path& dir);
// Read the files a server / a client needs from `dir`; throw std::runtime_error naming a missing or
// malformed file.
ServerSecurity loadServerSecurity(const std::filesystem::path& dir);
ClientSecurity loadClientSecurity(const std::filesystem::path& dir);

// Throws std::invalid_argument if `endpoint` is not inproc://, ipc:// or tcp://HOST:PORT, if it is
// tcp:// on a non-loopback host while `with_curve` is false, or if it is ipc://PATH where PATH
// exists and is not a socket.
void checkBindEndpoint(const std::string& endpoint, bool with_curve);

// The connection a request came on: ZeroMQ's routing id, and whether the peer framed it with the
// empty delimiter of a REQ socket (the reply is framed the same way).
struct PeerAddress {
  std::string routing_id;
  bool delimited = true;
  bool operator==(const PeerAddress&) const = default;
};

struct Incoming {
  PeerAddress from;
  Multipart message;
};

class ServerSocket {
 public:
  // Binds `endpoint` (tcp port "*" picks a free port; see endpoint()).
  ServerSocket(Context& context, const std::string& endpoint,
               const std::optional<ServerSecurity>& security = std::nullopt);
  ~ServerSocket();
  ServerSocket(const ServerSocket&) = delete;
  ServerSocket& operator=(const ServerSocket&) = delete;

  // The endpoint actually bound (with the chosen port).
  const std::string& endpoint() const { return endpoint_; }
  // Next request, or nothing after `timeout`. A message without a routing envelope is dropped.
  std::optional<Incoming> receive(std::chrono::milliseconds timeout);
  // Reply to the connection `to` (dropped by ZeroMQ if it has gone).
  void send(const PeerAddress& to, const Multipart& reply);

 private:
  class ZapHandler;
  struct Sockets;
  std::unique_ptr<ZapHandler> zap_;
  std::unique_ptr<Sockets> sockets_;
  std::string endpoint_;
};

class ClientSocket {
 public:
  ClientSocket(Context& context, const std::string& endpoint, std::chrono::milliseconds timeout,
               const std::optional<ClientSecurity>& security = std::nullopt);
  ~ClientSocket();
  ClientSocket(const ClientSocket&) = delete;
  ClientSocket& operator=(const ClientSocket&) = delete;

  // Sends `request` and waits for the reply (see the timeout contract above). With `meanwhile`,
  // calls it once the request is sent and before waiting, so the caller's own work overlaps the
  // peer's; the timeout counts from its return. An exception from `meanwhile` is rethrown after the
  // reply has arrived (the socket stays in step with its peer) or, if the wait fails, in place of
  // the wait's error.
  Multipart request(const Multipart& request, const std::function<void()>& meanwhile = {});
  const std::string& endpoint() const { return endpoint_; }

 private:
  Multipart awaitReply(const std::string& seconds);  // `seconds`: the timeout, for the messages

  struct Sockets;
  std::unique_ptr<Sockets> sockets_;
  std::string endpoint_;
  std::chrono::milliseconds timeout_;
  bool broken_ = false;
};

}  // namespace demfem::protocol
