#include "demfem/protocol/transport.hpp"

#include <zmq.hpp>
#include <zmq_addon.hpp>

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <exception>
#include <fstream>
#include <regex>
#include <set>
#include <stdexcept>
#include <thread>

namespace demfem::protocol {

namespace fs = std::filesystem;

namespace {

constexpr const char* kZapEndpoint = "inproc://zeromq.zap.01";  // fixed by the ZAP RFC 27
constexpr auto kZapPoll = std::chrono::milliseconds(100);
constexpr auto kMonitorPoll = std::chrono::milliseconds(50);

std::string readKeyFile(const fs::path& file, bool secret) {
  std::error_code error;
  const fs::perms mode = fs::status(file, error).permissions();
  if (secret && !error && (mode & (fs::perms::group_all | fs::perms::others_all)) != fs::perms::none)
    throw std::runtime_error("CurveZMQ secret key file " + file.string() +
                             " is accessible to other users (it must be mode 0600: chmod 600 it)");
  std::ifstream in(file);
  if (!in) throw std::runtime_error("CurveZMQ key file " + file.string() + " cannot be read");
  std::string key;
  std::getline(in, key);
  while (!key.empty() && (key.back() == '\r' || key.back() == ' ')) key.pop_back();
  if (key.size() != 40)
    throw std::runtime_error("CurveZMQ key file " + file.string() + ": expected one 40-character Z85 key, got " +
                             std::to_string(key.size()) + " characters");
  return key;
}

void writeKeyFile(const fs::path& file, const std::string& key, bool secret) {
  std::ofstream out(file, std::ios::trunc);
  if (!out) throw std::runtime_error("cannot write CurveZMQ key file " + file.string());
  // The mode is set while the file is still empty: a secret key is never readable by others.
  fs::permissions(file, secret ? fs::perms::owner_read | fs::perms::owner_write
                               : fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                                     fs::perms::others_read);
  out << key << '\n';
  out.close();
  if (!out) throw std::runtime_error("cannot write CurveZMQ key file " + file.string() + " (disk full?)");
}

CurveKeyPair newKeyPair() {
  char pub[41] = {}, sec[41] = {};
  if (zmq_curve_keypair(pub, sec) != 0)
    throw std::runtime_error(std::string("zmq_curve_keypair failed: ") + zmq_strerror(zmq_errno()));
  return {pub, sec};
}

std::string z85Of(const zmq::message_t& binary_key) {
  if (binary_key.size() != 32) return {};
  char text[41] = {};
  zmq_z85_encode(text, static_cast<const std::uint8_t*>(binary_key.data()), 32);
  return text;
}

}  // namespace

void writeCurveKeyDirectory(const fs::path& dir) {
  fs::create_directories(dir);
  const CurveKeyPair server = newKeyPair(), client = newKeyPair();
  writeKeyFile(dir / "server.pub", server.public_key, false);
  writeKeyFile(dir / "server.secret", server.secret_key, true);
  writeKeyFile(dir / "client.pub", client.public_key, false);
  writeKeyFile(dir / "client.secret", client.secret_key, true);
}

ServerSecurity loadServerSecurity(const fs::path& dir) {
  return {{readKeyFile(dir / "server.pub", false), readKeyFile(dir / "server.secret", true)},
          readKeyFile(dir / "client.pub", false)};
}

ClientSecurity loadClientSecurity(const fs::path& dir) {
  return {readKeyFile(dir / "server.pub", false),
          {readKeyFile(dir / "client.pub", false), readKeyFile(dir / "client.secret", true)}};
}

void checkBindEndpoint(const std::string& endpoint, bool with_curve, bool insecure_tcp) {
  if (endpoint.rfind("inproc://", 0) == 0) return;
  if (endpoint.rfind("ipc://", 0) == 0) {
    const fs::path path = endpoint.substr(6);
    std::error_code error;
    const fs::file_status status = fs::symlink_status(path, error);
    if (fs::exists(status) && status.type() != fs::file_type::socket)
      throw std::invalid_argument("refusing to bind '" + endpoint + "': " + path.string() +
                                  " exists and is not a socket (binding would delete it)");
    return;
  }
  static const std::regex tcp(R"(tcp://(\[[^\]]+\]|[^:\[\]]+):(\d+|\*))");
  std::smatch m;
  if (!std::regex_match(endpoint, m, tcp))
    throw std::invalid_argument("endpoint '" + endpoint +
                                "' is not inproc://NAME, ipc://PATH or tcp://HOST:PORT (PORT may be *)");
  const std::string host = m[1];
  const bool loopback = host == "localhost" || host == "[::1]" || host.rfind("127.", 0) == 0;
  if (with_curve) return;
  if (!loopback)
    throw std::invalid_argument("refusing to serve on non-loopback address '" + host +
                                "' without authentication: pass --curve-keys DIR (CurveZMQ keys, made by "
                                "demfem-dem --make-curve-keys DIR)");
  if (!insecure_tcp)
    throw std::invalid_argument("refusing to serve '" + endpoint +
                                "' without authentication: any local process could take the session first or "
                                "flood it; pass --curve-keys DIR (made by demfem-dem --make-curve-keys DIR), serve "
                                "ipc://PATH (only your own processes can connect), or accept that with --insecure");
}

// ZAP handler (RFC 27): accepts a CURVE client only if its public key is the authorized one.
class ServerSocket::ZapHandler {
 public:
  ZapHandler(zmq::context_t& context, std::string authorized_key)
      : socket_(context, zmq::socket_type::rep), authorized_(std::move(authorized_key)) {
    socket_.set(zmq::sockopt::linger, 0);
    socket_.bind(kZapEndpoint);
    thread_ = std::thread([this] { run(); });
  }
  ~ZapHandler() {
    stop_ = true;
    thread_.join();
  }

 private:
  void run() {
    while (!stop_) {
      zmq::pollitem_t item{socket_.handle(), 0, ZMQ_POLLIN, 0};
      if (zmq::poll(&item, 1, kZapPoll) == 0) continue;
      std::vector<zmq::message_t> frames;
      if (!zmq::recv_multipart(socket_, std::back_inserter(frames), zmq::recv_flags::dontwait)) continue;
      // version, request id, domain, address, identity, mechanism, credentials...
      const bool ok = frames.size() >= 7 && frames[5].to_string() == "CURVE" && z85Of(frames[6]) == authorized_;
      std::vector<zmq::message_t> reply;
      reply.emplace_back(std::string("1.0"));
      reply.emplace_back(frames.size() > 1 ? frames[1].to_string() : std::string());
      reply.emplace_back(std::string(ok ? "200" : "400"));
      reply.emplace_back(std::string(ok ? "OK" : "client key not authorized"));
      reply.emplace_back(std::string());
      reply.emplace_back(std::string());
      zmq::send_multipart(socket_, reply);
    }
  }

  zmq::socket_t socket_;
  std::string authorized_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Watches the connections of a tcp:// server socket (zmq_socket_monitor) from its own thread and
// closes every connection but the owner's when there are too many or accepting one failed
// (transport.hpp contract "Connection limits").
class ServerSocket::ConnectionGuard {
 public:
  ConnectionGuard(zmq::context_t& context, zmq::socket_t& socket, const std::string& bound_endpoint,
                  std::size_t max_connections, std::function<void(const std::string&)> log)
      : monitor_(context, zmq::socket_type::pair), max_connections_(max_connections), log_(std::move(log)) {
    port_ = static_cast<std::uint16_t>(std::stoul(bound_endpoint.substr(bound_endpoint.rfind(':') + 1)));
    static std::atomic<std::uint64_t> monitors{0};
    const std::string name = "inproc://demfem-server-monitor-" + std::to_string(++monitors);
    if (zmq_socket_monitor(socket.handle(), name.c_str(),
                           ZMQ_EVENT_ACCEPTED | ZMQ_EVENT_ACCEPT_FAILED | ZMQ_EVENT_DISCONNECTED) != 0)
      throw std::runtime_error(std::string("zmq_socket_monitor failed: ") + zmq_strerror(zmq_errno()));
    monitor_.set(zmq::sockopt::linger, 0);
    monitor_.connect(name);
    thread_ = std::thread([this] { run(); });
  }
  ~ConnectionGuard() {
    stop_ = true;
    thread_.join();
  }
  void setOwnerFd(int fd) { owner_fd_ = fd; }
  std::size_t sheddings() const { return sheddings_; }

 private:
  void run() {
    bool accept_failed_since_shed = true;  // failures queued before a shedding are stale
    while (!stop_) {
      zmq::pollitem_t item{monitor_.handle(), 0, ZMQ_POLLIN, 0};
      if (zmq::poll(&item, 1, kMonitorPoll) == 0) continue;
      std::vector<zmq::message_t> event;
      if (!zmq::recv_multipart(monitor_, std::back_inserter(event), zmq::recv_flags::dontwait) || event.empty() ||
          event[0].size() < 6)
        continue;
      // Frame 0 of a monitor event: u16 event id, u32 value (here a file descriptor or an errno).
      std::uint16_t id = 0;
      std::uint32_t value = 0;
      std::memcpy(&id, event[0].data(), sizeof id);
      std::memcpy(&value, static_cast<const char*>(event[0].data()) + 2, sizeof value);
      const int fd = static_cast<int>(value);
      if (id == ZMQ_EVENT_ACCEPTED) {
        accept_failed_since_shed = false;
        open_.insert(fd);
        if (open_.size() > max_connections_)
          shed(std::to_string(open_.size()) + " connections open, more than the limit of " +
               std::to_string(max_connections_));
      } else if (id == ZMQ_EVENT_DISCONNECTED) {
        open_.erase(fd);
      } else if (id == ZMQ_EVENT_ACCEPT_FAILED && !accept_failed_since_shed) {
        accept_failed_since_shed = true;
        shed(std::string("accepting a connection failed (") + std::strerror(fd) + ")");
      }
    }
  }

  // True if `fd` is a connection accepted on our port, not a listening socket (a closed number may
  // have been reused).
  bool acceptedHere(int fd) const {
    int listening = 0;
    socklen_t flag_length = sizeof listening;
    if (getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &listening, &flag_length) != 0 || listening != 0) return false;
    sockaddr_storage address{};
    socklen_t length = sizeof address;
    if (getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) return false;
    if (address.ss_family == AF_INET) return ntohs(reinterpret_cast<const sockaddr_in&>(address).sin_port) == port_;
    if (address.ss_family == AF_INET6) return ntohs(reinterpret_cast<const sockaddr_in6&>(address).sin6_port) == port_;
    return false;
  }

  void shed(const std::string& reason) {
    const int owner = owner_fd_;
    std::size_t closed = 0;
    for (const int fd : open_)
      if (fd != owner && acceptedHere(fd) && ::shutdown(fd, SHUT_RDWR) == 0) ++closed;
    const bool owner_open = open_.count(owner) > 0;
    open_.clear();
    if (owner_open) open_.insert(owner);
    if (++sheddings_ == 1 && log_)
      log_(reason + ": closed " + std::to_string(closed) +
           " connections, every one but the session owner's (logged once; docs/protocol.md \"Sockets and transports\")");
  }

  zmq::socket_t monitor_;
  std::size_t max_connections_;
  std::function<void(const std::string&)> log_;
  std::uint16_t port_ = 0;
  std::set<int> open_;  // accepted connections, monitor thread only
  std::atomic<int> owner_fd_{-1};
  std::atomic<std::size_t> sheddings_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct Context::Impl {
  zmq::context_t context{1};
};

Context::Context() : impl_(std::make_unique<Impl>()) {}
Context::~Context() = default;

struct ServerSocket::Sockets {
  zmq::socket_t socket;
};

struct ClientSocket::Sockets {
  zmq::socket_t socket;
  zmq::socket_t monitor;  // handshake events: tells a refused key from a silent peer
};

ServerSocket::ServerSocket(Context& shared, const std::string& endpoint, ServerSocketOptions options)
    : sockets_(std::make_unique<Sockets>()) {
  zmq::context_t& context = shared.impl_->context;
  const auto& security = options.security;
  checkBindEndpoint(endpoint, security.has_value(), options.insecure_tcp);
  if (security) zap_ = std::make_unique<ZapHandler>(context, security->authorized_client_key);
  sockets_->socket = zmq::socket_t(context, zmq::socket_type::router);
  sockets_->socket.set(zmq::sockopt::linger, 0);
  sockets_->socket.set(zmq::sockopt::maxmsgsize, static_cast<std::int64_t>(kMaxFrameBytes));
  sockets_->socket.set(zmq::sockopt::handshake_ivl, static_cast<int>(options.handshake_timeout.count()));
  if (security) {
    sockets_->socket.set(zmq::sockopt::curve_server, 1);
    sockets_->socket.set(zmq::sockopt::curve_secretkey, security->server.secret_key);
    sockets_->socket.set(zmq::sockopt::zap_domain, "demfem");
  }
  const bool ipc = endpoint.rfind("ipc://", 0) == 0;
  // The socket file of ipc:// is created by bind(2) with the umask's mode: 0600, the user's only.
  const mode_t umask_before = ipc ? ::umask(0177) : 0;
  try {
    sockets_->socket.bind(endpoint);
  } catch (const zmq::error_t& e) {
    if (ipc) ::umask(umask_before);
    throw std::runtime_error("cannot bind " + endpoint + ": " + e.what());
  }
  if (ipc) ::umask(umask_before);
  endpoint_ = sockets_->socket.get(zmq::sockopt::last_endpoint);
  if (endpoint.rfind("tcp://", 0) == 0)
    guard_ = std::make_unique<ConnectionGuard>(context, sockets_->socket, endpoint_, options.max_connections,
                                               std::move(options.log));
}

ServerSocket::~ServerSocket() {
  if (guard_) {
    zmq_socket_monitor(sockets_->socket.handle(), nullptr, 0);
    guard_.reset();
  }
  sockets_->socket.close();  // before the ZAP handler goes
}

void ServerSocket::setOwner(const std::optional<PeerAddress>& owner) {
  const std::optional<std::string> id = owner ? std::optional(owner->routing_id) : std::nullopt;
  if (id == owner_) return;  // receive() keeps the owner's socket up to date
  owner_ = id;
  if (guard_) guard_->setOwnerFd(id && *id == last_routing_id_ ? last_fd_ : -1);
}

std::size_t ServerSocket::connectionSheddings() const { return guard_ ? guard_->sheddings() : 0; }

std::optional<Incoming> ServerSocket::receive(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  zmq::socket_t& socket = sockets_->socket;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
    if (left.count() <= 0 || zmq::poll(&item, 1, left) == 0) return std::nullopt;
    zmq::message_t routing_id;
    if (!socket.recv(routing_id, zmq::recv_flags::dontwait)) continue;
    Incoming in;
    in.from.routing_id = routing_id.to_string();
    const bool owned = owner_ && *owner_ == in.from.routing_id;
    // Frame by frame (ZeroMQ delivers a message whole, so the rest is there): a non-owner's message
    // stops being kept once it is larger than a hello, and each frame is freed as it is read.
    bool more = routing_id.more(), first = true;
    const bool enveloped = more;
    std::size_t bytes = 0, frames = 0;
    int fd = -1;
    while (more) {
      zmq::message_t frame;
      if (!socket.recv(frame, zmq::recv_flags::dontwait)) break;
      more = frame.more();
      if (fd < 0) fd = zmq_msg_get(frame.handle(), ZMQ_SRCFD);
      if (first) {
        first = false;
        // A REQ peer puts an empty delimiter between the routing id and frame 0.
        in.from.delimited = frame.size() == 0;
        if (in.from.delimited) continue;
      }
      bytes += frame.size();
      ++frames;
      if (!owned && (bytes > kMaxUnownedRequestBytes || frames > kMaxFrames)) {
        if (!in.dropped) Multipart().swap(in.message);
        in.dropped = true;
      } else {
        in.message.emplace_back(static_cast<const char*>(frame.data()), frame.size());
      }
    }
    if (!enveloped) continue;
    in.bytes = bytes;
    last_routing_id_ = in.from.routing_id;
    last_fd_ = fd;
    if (owned && guard_) guard_->setOwnerFd(fd);
    return in;
  }
}

void ServerSocket::send(const PeerAddress& to, const Multipart& reply) {
  std::vector<zmq::const_buffer> buffers;
  buffers.reserve(reply.size() + 2);
  buffers.emplace_back(to.routing_id.data(), to.routing_id.size());
  if (to.delimited) buffers.emplace_back(nullptr, 0);
  for (const auto& f : reply) buffers.emplace_back(f.data(), f.size());
  (void)zmq::send_multipart(sockets_->socket, buffers, zmq::send_flags::dontwait);
}

ClientSocket::ClientSocket(Context& shared, const std::string& endpoint, std::chrono::milliseconds timeout,
                           const std::optional<ClientSecurity>& security)
    : sockets_(std::make_unique<Sockets>()), endpoint_(endpoint), timeout_(timeout) {
  zmq::context_t& context = shared.impl_->context;
  sockets_->socket = zmq::socket_t(context, zmq::socket_type::req);
  sockets_->socket.set(zmq::sockopt::linger, 0);
  sockets_->socket.set(zmq::sockopt::maxmsgsize, static_cast<std::int64_t>(kMaxFrameBytes));
  sockets_->socket.set(zmq::sockopt::sndtimeo, static_cast<int>(timeout.count()));
  if (security) {
    sockets_->socket.set(zmq::sockopt::curve_serverkey, security->server_public_key);
    sockets_->socket.set(zmq::sockopt::curve_publickey, security->client.public_key);
    sockets_->socket.set(zmq::sockopt::curve_secretkey, security->client.secret_key);
  }
  // A name never used before in this process: a socket at the address of a closed one would find its
  // monitor endpoint still bound, for ZeroMQ unbinds it asynchronously (EADDRINUSE).
  static std::atomic<std::uint64_t> monitors{0};
  const std::string monitor_endpoint = "inproc://demfem-client-monitor-" + std::to_string(++monitors);
  if (zmq_socket_monitor(sockets_->socket.handle(), monitor_endpoint.c_str(),
                         ZMQ_EVENT_HANDSHAKE_FAILED_AUTH | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                             ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL | ZMQ_EVENT_DISCONNECTED) != 0)
    throw std::runtime_error(std::string("zmq_socket_monitor failed: ") + zmq_strerror(zmq_errno()));
  sockets_->monitor = zmq::socket_t(context, zmq::socket_type::pair);
  sockets_->monitor.set(zmq::sockopt::linger, 0);
  sockets_->monitor.connect(monitor_endpoint);
  try {
    sockets_->socket.connect(endpoint);
  } catch (const zmq::error_t& e) {
    throw std::invalid_argument("cannot connect to '" + endpoint + "': " + e.what());
  }
}

ClientSocket::~ClientSocket() {
  zmq_socket_monitor(sockets_->socket.handle(), nullptr, 0);
  sockets_->monitor.close();
  sockets_->socket.close();
}

Multipart ClientSocket::request(const Multipart& request, const std::function<void()>& meanwhile) {
  if (broken_)
    throw ProtocolError(WireError::PeerGone, "connection to " + endpoint_ + " is unusable after an earlier failure");
  std::vector<zmq::const_buffer> buffers;
  for (const auto& f : request) buffers.emplace_back(f.data(), f.size());
  const std::string seconds = std::to_string(static_cast<double>(timeout_.count()) / 1000.0);
  if (!zmq::send_multipart(sockets_->socket, buffers)) {
    broken_ = true;
    throw ProtocolError(WireError::Timeout, "could not send to " + endpoint_ + " within " + seconds + " s");
  }
  std::exception_ptr meanwhile_error;
  if (meanwhile) {
    try {
      meanwhile();
    } catch (...) {
      meanwhile_error = std::current_exception();
    }
  }
  Multipart reply;
  try {
    reply = awaitReply(seconds);
  } catch (const ProtocolError&) {
    if (meanwhile_error) std::rethrow_exception(meanwhile_error);
    throw;
  }
  if (meanwhile_error) std::rethrow_exception(meanwhile_error);
  return reply;
}

Multipart ClientSocket::awaitReply(const std::string& seconds) {
  const auto deadline = std::chrono::steady_clock::now() + timeout_;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    zmq::pollitem_t items[2] = {{sockets_->socket.handle(), 0, ZMQ_POLLIN, 0}, {sockets_->monitor.handle(), 0, ZMQ_POLLIN, 0}};
    try {
      zmq::poll(items, 2, left);
    } catch (const zmq::error_t& e) {
      broken_ = true;
      throw ProtocolError(WireError::Internal, "waiting for " + endpoint_ + " was interrupted (" + e.what() + ")");
    }
    if (items[1].revents & ZMQ_POLLIN) {
      std::vector<zmq::message_t> event;
      (void)zmq::recv_multipart(sockets_->monitor, std::back_inserter(event));
      broken_ = true;
      // Frame 0 of a monitor event: u16 event id, u32 value.
      std::uint16_t id = 0;
      if (!event.empty() && event[0].size() >= sizeof id) std::memcpy(&id, event[0].data(), sizeof id);
      if (id == ZMQ_EVENT_DISCONNECTED)
        throw ProtocolError(WireError::PeerGone, "the DEM server at " + endpoint_ +
                                                     " closed the connection (it stopped or crashed); no reply will come");
      throw ProtocolError(WireError::PeerGone,
                          "the server at " + endpoint_ +
                              " refused the connection during the security handshake (wrong or missing "
                              "CurveZMQ key? check --curve-keys)");
    }
    if (items[0].revents & ZMQ_POLLIN) {
      std::vector<zmq::message_t> frames;
      (void)zmq::recv_multipart(sockets_->socket, std::back_inserter(frames));
      Multipart reply;
      for (auto& f : frames) reply.emplace_back(static_cast<const char*>(f.data()), f.size());
      return reply;
    }
  }
  broken_ = true;
  throw ProtocolError(WireError::Timeout, "no reply from the DEM server at " + endpoint_ + " within " + seconds +
                                              " s: the peer is gone, hung, or refused this client");
}

}  // namespace demfem::protocol
