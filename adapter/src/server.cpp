#include "demfem/adapter/server.hpp"

#include "wire_conversions.hpp"

#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>

namespace demfem::adapter {


namespace p = protocol;

namespace {

template <class... F> struct Overloaded : F... { using F::operator()...; };
template <class... F> Overloaded(F...) -> Overloaded<F...>;

std::string secondsText(std::chrono::milliseconds ms) {
  std::ostringstream text;
  text << static_cast<double>(ms.count()) / 1000.0 << " s";
  return text.str();
}

// 128 random bits as 32 hex digits.
std::string newSessionToken() {
  std::random_device random;
  std::string token;
  for (int i = 0; i < 4; ++i) {
    char part[9];
    std::snprintf(part, sizeof part, "%08x", static_cast<unsigned>(random()));
    token += part;
  }
  return token;
}

// The answer to a request dropped unread by the transport (too large for a non-owner).
p::Multipart droppedReply(const p::Incoming& in) {
  return p::encode(p::Reply{0, "error", p::ErrorReply{p::WireError::BadRequest,
                                                     "request of " + std::to_string(in.bytes) + "+ bytes from " +
                                                         "a connection that does not own the session: dropped "
                                                         "unread (only a hello, at most " +
                                                         std::to_string(p::kMaxUnownedRequestBytes) + " bytes, is read)"}});
}

}  // namespace

Server::Server(CouplingApi& api, ServerOptions options) : api_(api), options_(std::move(options)) {}

bool Server::sessionOpen(Clock::time_point now) const {
  return session_ && now - session_->last_seen <= options_.idle_timeout;
}

bool Server::endIdleSession(Clock::time_point now) {
  if (!session_ || sessionOpen(now)) return false;
  log("session ended: its client sent nothing for " + secondsText(options_.idle_timeout));
  session_.reset();
  return true;
}

void Server::log(const std::string& text) const {
  if (options_.log) options_.log(text);
}

p::ReplyBody Server::hello(const p::PeerAddress& from, const p::Request& request, Clock::time_point now) {
  if (session_ && from.routing_id != session_->owner.routing_id)
    throw CouplingError(ErrorCode::Busy, "busy: this server is serving another client; a new session can start "
                                         "after it shuts down or sends nothing for " +
                                             secondsText(options_.idle_timeout));
  const auto& r = std::get<p::Hello>(request.body);
  if (r.protocol_version != p::kProtocolVersion)
    throw CouplingError(ErrorCode::VersionMismatch, "client speaks protocol version " +
                                                        std::to_string(r.protocol_version) + ", this server version " +
                                                        std::to_string(p::kProtocolVersion));
  const BackendInfo info = api_.info();
  session_ = Session{from, newSessionToken(), request.seq, now};
  log("session opened by '" + r.client + "'");
  p::HelloReply reply{p::kProtocolVersion, info.backend, info.version, info.dem_time_step_s,
                      session_->token,      options_.max_simulate_s};
  reply.soil_json = info.soil_json;
  reply.advance = true;
  return reply;
}

void Server::checkOwner(const p::PeerAddress& from, const p::Request& request, Clock::time_point now) {
  if (!session_)
    throw CouplingError(ErrorCode::BadRequest, "the first request of a session must be 'hello', got '" +
                                                   p::opName(request.body) + "'");
  if (from.routing_id != session_->owner.routing_id || request.session != session_->token)
    throw CouplingError(ErrorCode::Busy, "busy: the session belongs to another connection (or the session token "
                                         "is wrong); say hello once it has ended");
  session_->last_seen = now;
  if (request.seq <= session_->last_seq)
    throw CouplingError(ErrorCode::BadRequest, "request out of order: seq " + std::to_string(request.seq) +
                                                   " after seq " + std::to_string(session_->last_seq));
}

std::filesystem::path Server::checkpointPath(const std::string& name) const {
  if (options_.checkpoint_dir.empty())
    throw CouplingError(ErrorCode::Unsupported,
                        "this server keeps no checkpoints (start demfem-dem with --checkpoint-dir DIR)");
  if (!p::isCheckpointName(name)) throw CouplingError(ErrorCode::BadRequest, "not a checkpoint name");
  return options_.checkpoint_dir / name;
}

namespace {

// The largest node coordinate a peer may set, in metres: far beyond any soil bin, far below where a
// cell index or a distance overflows (docs/reliability.md, "Inputs checked against physics").
constexpr double kMaxCoordinate_m = 1e3;

void checkPositions(const NodeArray& xyz) {
  for (std::size_t i = 0; i < xyz.size(); ++i) {
    if (std::abs(xyz[i]) <= kMaxCoordinate_m) continue;
    throw CouplingError(ErrorCode::BadRequest, "node " + std::to_string(i / 3) + ": coordinate " + "xyz"[i % 3] + " = " +
                                                   std::to_string(xyz[i]) + " m is outside +-" + std::to_string(kMaxCoordinate_m) +
                                                   " m or not a number (nothing was moved)");
  }
}

}  // namespace

void Server::checkDuration(double duration_s) const {
  if (!(duration_s <= options_.max_simulate_s))
    throw CouplingError(ErrorCode::BadRequest,
                        "simulate duration " + std::to_string(duration_s) + " s exceeds this server's limit of " +
                            std::to_string(options_.max_simulate_s) +
                            " s per call (demfem-dem --max-simulate-s, study coupling.max_simulate_s)");
}

p::ReplyBody Server::serveCall(const p::Request& request) {
  return std::visit(
      Overloaded{
          [&](const p::Hello&) -> p::ReplyBody { throw CouplingError(ErrorCode::Internal, "hello dispatched as a call"); },
          [&](const p::ListGeometries&) -> p::ReplyBody {
            p::GeometriesReply reply;
            for (auto& g : api_.geometries()) reply.geometries.push_back({g.name, g.node_count, std::move(g.triangles)});
            return reply;
          },
          [&](const p::GetTime&) -> p::ReplyBody { return p::TimeReply{api_.time()}; },
          [&](const p::GetNodePositions& r) -> p::ReplyBody {
            return p::NodeArrayReply{r.geometry, api_.nodePositions(r.geometry)};
          },
          [&](const p::GetNodeForces& r) -> p::ReplyBody {
            return p::NodeArrayReply{r.geometry, api_.nodeForces(r.geometry, wire::toApi(r.mode))};
          },
          [&](const p::SetNodePositions& r) -> p::ReplyBody {
            checkPositions(r.xyz);
            api_.setNodePositions(r.geometry, r.xyz);
            return p::Ack{};
          },
          [&](const p::Simulate& r) -> p::ReplyBody {
            checkDuration(r.duration_s);
            api_.simulate(r.duration_s);
            return p::TimeReply{api_.time()};
          },
          [&](const p::Advance& r) -> p::ReplyBody {
            checkDuration(r.duration_s);
            checkPositions(r.xyz);
            NodeArray forces = api_.advance(r.geometry, r.xyz, r.duration_s, wire::toApi(r.mode), {});
            return p::AdvanceReply{api_.time(), r.geometry, std::move(forces)};
          },
          [&](const p::GetRigidMotion& r) -> p::ReplyBody {
            return p::RigidMotionReply{wire::toWire(api_.rigidMotion(r.geometry))};
          },
          [&](const p::SetRigidMotion& r) -> p::ReplyBody {
            api_.setRigidMotion(r.geometry, wire::toApi(r.motion));
            return p::Ack{};
          },
          [&](const p::Checkpoint& r) -> p::ReplyBody {
            api_.checkpoint(checkpointPath(r.name));
            return p::Ack{};
          },
          [&](const p::Restore& r) -> p::ReplyBody {
            const auto file = checkpointPath(r.name);
            try {
              api_.restore(file);
            } catch (const std::exception& e) {
              const auto* coupling = dynamic_cast<const CouplingError*>(&e);
              if (coupling && coupling->code() == ErrorCode::Unsupported) throw;
              log("restore of checkpoint '" + r.name + "' failed: " + e.what());
              throw CouplingError(ErrorCode::BadRequest, "restore of checkpoint '" + r.name +
                                                             "' failed: no valid checkpoint of that name (state unchanged)");
            }
            return p::Ack{};
          },
          [&](const p::Shutdown&) -> p::ReplyBody {
            api_.shutdown();
            shutdown_done_ = true;
            session_.reset();
            return p::Ack{};
          },
      },
      request.body);
}

p::ReplyBody Server::dispatch(const p::PeerAddress& from, const p::Request& request, Clock::time_point now) {
  if (shutdown_done_) throw CouplingError(ErrorCode::BadRequest, "the backend has been shut down");
  endIdleSession(now);
  if (std::holds_alternative<p::Hello>(request.body)) return hello(from, request, now);
  checkOwner(from, request, now);
  p::ReplyBody reply = serveCall(request);
  if (session_) session_->last_seq = request.seq;
  return reply;
}

p::Multipart Server::handle(const p::PeerAddress& from, const p::Multipart& message, Clock::time_point now) noexcept {
  try {
    p::Request request;
    try {
      request = p::decodeRequest(message);
    } catch (const p::ProtocolError& e) {
      return p::encode(p::errorReplyFor(message, e.code(), e.what()));
    }
    p::Reply reply{request.seq, p::opName(request.body), p::Ack{}};
    try {
      reply.body = dispatch(from, request, now);
    } catch (const CouplingError& e) {
      reply.body = p::ErrorReply{wire::toWire(e.code()), e.what()};
    } catch (const std::exception& e) {
      reply.body = p::ErrorReply{p::WireError::Internal, std::string("backend failure: ") + e.what()};
    }
    return p::encode(reply);
  } catch (...) {
    // Only reachable if encoding itself fails (out of memory): a minimal fixed error reply.
    return {R"({"v":1,"op":"error","seq":0,"error":{"code":9,"message":"server could not encode its reply"}})"};
  }
}

void Server::serve(p::ServerSocket& socket, std::chrono::milliseconds hello_timeout) {
  // Without a session: wait for a hello up to hello_timeout at the start, and up to the idle timeout
  // after a session ended (its client may reconnect).
  auto waiting_since = Clock::now();
  auto window = hello_timeout;
  while (!shutdown_done_) {
    const auto now = Clock::now();
    if (endIdleSession(now)) {
      waiting_since = now;
      window = options_.idle_timeout;
    }
    const bool open = session_.has_value();
    const auto deadline = open ? session_->last_seen + options_.idle_timeout : waiting_since + window;
    if (!open && now >= deadline) {
      api_.shutdown();
      throw CouplingError(ErrorCode::PeerGone, "no request from a FEM client on " + socket.endpoint() + " within " +
                                                   secondsText(window) + " (no session open); backend shut down");
    }
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now) + std::chrono::milliseconds(1);
    socket.setOwner(session_ ? std::optional(session_->owner) : std::nullopt);
    if (auto in = socket.receive(wait)) socket.send(in->from, in->dropped ? droppedReply(*in) : handle(in->from, in->message));
  }
}

}  // namespace demfem::adapter
