#include "demfem/adapter/server.hpp"

#include "wire_conversions.hpp"

#include <cmath>
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

}  // namespace

Server::Server(CouplingApi& api) : api_(api) {}

p::ReplyBody Server::dispatch(const p::Request& request) {
  if (shutdown_done_) throw CouplingError(ErrorCode::BadRequest, "the backend has been shut down");
  const bool is_hello = std::holds_alternative<p::Hello>(request.body);
  if (!hello_done_ && !is_hello)
    throw CouplingError(ErrorCode::BadRequest, "the first request of a session must be 'hello', got '" +
                                                   p::opName(request.body) + "'");
  if (hello_done_ && request.seq <= last_seq_)
    throw CouplingError(ErrorCode::BadRequest, "request out of order: seq " + std::to_string(request.seq) +
                                                   " after seq " + std::to_string(last_seq_));
  return std::visit(
      Overloaded{
          [&](const p::Hello& r) -> p::ReplyBody {
            if (r.protocol_version != p::kProtocolVersion)
              throw CouplingError(ErrorCode::VersionMismatch,
                                  "client speaks protocol version " + std::to_string(r.protocol_version) +
                                      ", this server version " + std::to_string(p::kProtocolVersion));
            const BackendInfo info = api_.info();
            hello_done_ = true;
            return p::HelloReply{p::kProtocolVersion, info.backend, info.version, info.dem_time_step_s, info.soil_json};
          },
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
            api_.setNodePositions(r.geometry, r.xyz);
            return p::Ack{};
          },
          [&](const p::Simulate& r) -> p::ReplyBody {
            api_.simulate(r.duration_s);
            return p::TimeReply{api_.time()};
          },
          [&](const p::GetRigidMotion& r) -> p::ReplyBody {
            return p::RigidMotionReply{wire::toWire(api_.rigidMotion(r.geometry))};
          },
          [&](const p::SetRigidMotion& r) -> p::ReplyBody {
            api_.setRigidMotion(r.geometry, wire::toApi(r.motion));
            return p::Ack{};
          },
          [&](const p::Checkpoint& r) -> p::ReplyBody {
            api_.checkpoint(r.file);
            return p::Ack{};
          },
          [&](const p::Restore& r) -> p::ReplyBody {
            api_.restore(r.file);
            return p::Ack{};
          },
          [&](const p::Shutdown&) -> p::ReplyBody {
            api_.shutdown();
            shutdown_done_ = true;
            return p::Ack{};
          },
      },
      request.body);
}

p::Multipart Server::handle(const p::Multipart& message) noexcept {
  try {
    p::Request request;
    try {
      request = p::decodeRequest(message);
    } catch (const p::ProtocolError& e) {
      return p::encode(p::errorReplyFor(message, e.code(), e.what()));
    }
    p::Reply reply{request.seq, p::opName(request.body), p::Ack{}};
    try {
      reply.body = dispatch(request);
      last_seq_ = request.seq;
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

void Server::serve(p::ServerSocket& socket, const ServeOptions& options) {
  while (!shutdown_done_) {
    const auto timeout = hello_done_ ? options.idle_timeout : options.first_request_timeout;
    auto request = socket.receive(timeout);
    if (!request) {
      api_.shutdown();
      throw CouplingError(ErrorCode::PeerGone, std::string("no request from a FEM client on ") + socket.endpoint() +
                                                   " within " + secondsText(timeout) +
                                                   (hello_done_ ? " (the client is gone?)" : " (no client connected)") +
                                                   "; backend shut down");
    }
    socket.send(handle(*request));
  }
}

}  // namespace demfem::adapter
