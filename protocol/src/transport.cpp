#include "demfem/protocol/transport.hpp"

#include <zmq.hpp>
#include <zmq_addon.hpp>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <exception>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <thread>

namespace demfem::protocol {

namespace fs = std::filesystem;

namespace {

constexpr const char* kZapEndpoint = "inproc://zeromq.zap.01";  // fixed by the ZAP RFC 27
constexpr auto kZapPoll = std::chrono::milliseconds(100);

std::string readKeyFile(const fs::path& file) {
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
  {
    std::ofstream out(file, std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write CurveZMQ key file " + file.string());
    out << key << '\n';
  }
  fs::permissions(file, secret ? fs::perms::owner_read | fs::perms::owner_write
                               : fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                                     fs::perms::others_read);
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
  return {{readKeyFile(dir / "server.pub"), readKeyFile(dir / "server.secret")}, readKeyFile(dir / "client.pub")};
}

ClientSecurity loadClientSecurity(const fs::path& dir) {
  return {readKeyFile(dir / "server.pub"), {readKeyFile(dir / "client.pub"), readKeyFile(dir / "client.secret")}};
}

void checkBindEndpoint(const std::string& endpoint, bool with_curve) {
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
  if (!loopback && !with_curve)
    throw std::invalid_argument("refusing to serve on non-loopback address '" + host +
                                "' without authentication: pass --curve-keys DIR (CurveZMQ) or bind 127.0.0.1");
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

ServerSocket::ServerSocket(Context& shared, const std::string& endpoint, const std::optional<ServerSecurity>& security)
    : sockets_(std::make_unique<Sockets>()) {
  zmq::context_t& context = shared.impl_->context;
  checkBindEndpoint(endpoint, security.has_value());
  if (security) zap_ = std::make_unique<ZapHandler>(context, security->authorized_client_key);
  sockets_->socket = zmq::socket_t(context, zmq::socket_type::router);
  sockets_->socket.set(zmq::sockopt::linger, 0);
  sockets_->socket.set(zmq::sockopt::maxmsgsize, static_cast<std::int64_t>(kMaxFrameBytes));
  if (security) {
    sockets_->socket.set(zmq::sockopt::curve_server, 1);
    sockets_->socket.set(zmq::sockopt::curve_secretkey, security->server.secret_key);
    sockets_->socket.set(zmq::sockopt::zap_domain, "demfem");
  }
  try {
    sockets_->socket.bind(endpoint);
  } catch (const zmq::error_t& e) {
    throw std::runtime_error("cannot bind " + endpoint + ": " + e.what());
  }
  endpoint_ = sockets_->socket.get(zmq::sockopt::last_endpoint);
}

ServerSocket::~ServerSocket() {
  sockets_->socket.close();  // before the ZAP handler goes
}

std::optional<Incoming> ServerSocket::receive(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    zmq::pollitem_t item{sockets_->socket.handle(), 0, ZMQ_POLLIN, 0};
    if (left.count() <= 0 || zmq::poll(&item, 1, left) == 0) return std::nullopt;
    std::vector<zmq::message_t> frames;
    if (!zmq::recv_multipart(sockets_->socket, std::back_inserter(frames)) || frames.size() < 2) continue;
    Incoming in;
    in.from.routing_id = frames[0].to_string();
    // A REQ peer puts an empty delimiter between the routing id and frame 0.
    in.from.delimited = frames[1].size() == 0;
    const std::size_t first = in.from.delimited ? 2 : 1;
    in.message.reserve(frames.size() - first);
    for (std::size_t i = first; i < frames.size(); ++i)
      in.message.emplace_back(static_cast<const char*>(frames[i].data()), frames[i].size());
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
