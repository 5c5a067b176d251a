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
// - Authentication off ipc (docs/protocol.md "Sockets and transports"): a server refuses to bind
//   tcp:// without CurveZMQ keys (then only the one listed client key gets through the handshake,
//   checked by a ZAP handler) unless ServerSocketOptions::insecure_tcp is set, and even then only on
//   a loopback address. ipc:// sockets are created with mode 0600 (umask 0177 while binding: the
//   process's umask is changed for that moment), so only the user's own processes can connect.
// - CurveZMQ key directory (made by writeCurveKeyDirectory(), keys from zmq_curve_keypair, Z85 text
//   one key per file): server.pub, server.secret, client.pub, client.secret. The server needs
//   server.secret and client.pub (the only client key it accepts, checked by a ZAP handler); the
//   client needs server.pub, client.pub and client.secret. A client with another key is refused:
//   its request() throws ProtocolError(PeerGone) naming the refusal.
// - A server that closes the connection (it stopped or crashed) makes the pending or next request()
//   throw ProtocolError(PeerGone) at once instead of waiting for the timeout.
// - Sizes: frames above kMaxFrameBytes are dropped by ZeroMQ (ZMQ_MAXMSGSIZE, the connection is
//   closed) before they reach the codec. ServerSocket::receive() reads a message from a connection
//   other than the owner (setOwner()) frame by frame and stops keeping it once it exceeds
//   kMaxUnownedRequestBytes or kMaxFrames: such a message comes back marked Incoming::dropped,
//   without frames, never copied or decoded.
// - Connection limits on tcp:// (a monitor thread of the server socket): a connection that has not
//   completed its handshake within ServerSocketOptions::handshake_timeout is closed by ZeroMQ
//   (ZMQ_HANDSHAKE_IVL). When more than ServerSocketOptions::max_connections connections are open,
//   or accepting one fails (no file descriptor left: ZeroMQ would retry at full CPU), every
//   connection but the owner's is closed (shutdown(2) on its socket), so the owner keeps being
//   served; the first time, ServerSocketOptions::log says so (later times are counted, not logged).
#pragma once

#include "demfem/protocol/codec.hpp"

#include <chrono>
#include <filesystem>
#include <cstddef>
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
// malformed file, or a secret file that group or others may access.
ServerSecurity loadServerSecurity(const std::filesystem::path& dir);
ClientSecurity loadClientSecurity(const std::filesystem::path& dir);

// Throws std::invalid_argument if `endpoint` is not inproc://, ipc:// or tcp://HOST:PORT, if it is
// tcp:// while `with_curve` is false (unless `insecure_tcp` and the host is a loopback address), or
// if it is ipc://PATH where PATH exists and is not a socket.
void checkBindEndpoint(const std::string& endpoint, bool with_curve, bool insecure_tcp = false);

// Largest message read from a connection that does not own the session: a hello is one header frame.
inline constexpr std::size_t kMaxUnownedRequestBytes = kMaxHeaderBytes;
// Defaults of ServerSocketOptions.
inline constexpr std::size_t kMaxConnections = 64;
inline constexpr std::chrono::milliseconds kHandshakeTimeout{5000};

struct ServerSocketOptions {
  std::optional<ServerSecurity> security{};  // CurveZMQ; required for tcp:// unless insecure_tcp
  // Serve tcp:// on a loopback address without authentication: any local process may then connect,
  // take the session before the real client and send it large messages (docs/protocol.md).
  bool insecure_tcp = false;
  std::size_t max_connections = kMaxConnections;             // tcp:// only, see the contract
  std::chrono::milliseconds handshake_timeout = kHandshakeTimeout;
  // Diagnostics (connections closed at the limit); called from the socket's monitor thread.
  std::function<void(const std::string&)> log{};
};

// The connection a request came on: ZeroMQ's routing id, and whether the peer framed it with the
// empty delimiter of a REQ socket (the reply is framed the same way).
struct PeerAddress {
  std::string routing_id;
  bool delimited = true;
  bool operator==(const PeerAddress&) const = default;
};

struct Incoming {
  PeerAddress from;
  Multipart message;      // empty if dropped
  bool dropped = false;   // a message too large for a non-owner: its frames were not kept
  std::size_t bytes = 0;  // bytes of the frames read (of a dropped message: up to where it was dropped)
};

class ServerSocket {
 public:
  // Binds `endpoint` (tcp port "*" picks a free port; see endpoint()); throws std::invalid_argument
  // as checkBindEndpoint() does, std::runtime_error if the bind fails.
  ServerSocket(Context& context, const std::string& endpoint, ServerSocketOptions options = {});
  ~ServerSocket();
  ServerSocket(const ServerSocket&) = delete;
  ServerSocket& operator=(const ServerSocket&) = delete;

  // The endpoint actually bound (with the chosen port).
  const std::string& endpoint() const { return endpoint_; }
  // Next request, or nothing after `timeout`. A message without a routing envelope is dropped; one
  // too large for a non-owner comes back marked dropped (see the contract).
  std::optional<Incoming> receive(std::chrono::milliseconds timeout);
  // Reply to the connection `to` (dropped by ZeroMQ if it has gone).
  void send(const PeerAddress& to, const Multipart& reply);
  // The connection that owns the session (nothing: none does). Its messages are read whole and its
  // connection is never closed at the connection limit.
  void setOwner(const std::optional<PeerAddress>& owner);
  // How many times connections were closed at the limit (see the contract).
  std::size_t connectionSheddings() const;

 private:
  class ZapHandler;
  class ConnectionGuard;
  struct Sockets;
  std::unique_ptr<ZapHandler> zap_;
  std::unique_ptr<Sockets> sockets_;
  std::unique_ptr<ConnectionGuard> guard_;
  std::string endpoint_;
  std::optional<std::string> owner_;  // routing id
  std::string last_routing_id_;       // of the last message received, and the socket it came on
  int last_fd_ = -1;
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
