#include "demfem/protocol/codec.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

namespace demfem::protocol {

static_assert(std::endian::native == std::endian::little,
              "the wire arrays are little-endian and copied as-is: add byte swapping for this host");

using nlohmann::json;

namespace {

// ---- operation names ----
template <class T> struct OpTag;
template <> struct OpTag<Hello> { static constexpr const char* name = "hello"; };
template <> struct OpTag<ListGeometries> { static constexpr const char* name = "list_geometries"; };
template <> struct OpTag<GetTime> { static constexpr const char* name = "get_time"; };
template <> struct OpTag<GetNodePositions> { static constexpr const char* name = "get_node_positions"; };
template <> struct OpTag<GetNodeForces> { static constexpr const char* name = "get_node_forces"; };
template <> struct OpTag<SetNodePositions> { static constexpr const char* name = "set_node_positions"; };
template <> struct OpTag<Simulate> { static constexpr const char* name = "simulate"; };
template <> struct OpTag<Advance> { static constexpr const char* name = "advance"; };
template <> struct OpTag<GetRigidMotion> { static constexpr const char* name = "get_rigid_motion"; };
template <> struct OpTag<SetRigidMotion> { static constexpr const char* name = "set_rigid_motion"; };
template <> struct OpTag<Checkpoint> { static constexpr const char* name = "checkpoint"; };
template <> struct OpTag<Restore> { static constexpr const char* name = "restore"; };
template <> struct OpTag<Shutdown> { static constexpr const char* name = "shutdown"; };

[[noreturn]] void bad(const std::string& message) { throw ProtocolError(WireError::BadRequest, message); }

std::string dumpHeader(const json& header) {
  // Replace rather than throw on invalid UTF-8 (error messages may quote file names).
  return header.dump(-1, ' ', false, json::error_handler_t::replace);
}

json parseHeader(const Multipart& message) {
  if (message.empty()) bad("empty message: frame 0 (JSON header) missing");
  if (message.size() > kMaxFrames)
    bad("message has " + std::to_string(message.size()) + " frames, limit " + std::to_string(kMaxFrames));
  const Frame& text = message[0];
  if (text.size() > kMaxHeaderBytes)
    bad("header frame is " + std::to_string(text.size()) + " bytes, limit " + std::to_string(kMaxHeaderBytes));
  for (std::size_t i = 1; i < message.size(); ++i)
    if (message[i].size() > kMaxFrameBytes)
      bad("frame " + std::to_string(i) + " is " + std::to_string(message[i].size()) + " bytes, limit " +
          std::to_string(kMaxFrameBytes));
  json header = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (header.is_discarded()) bad("frame 0 is not valid JSON");
  if (!header.is_object()) bad("frame 0 must be a JSON object");
  const auto v = header.find("v");
  if (v == header.end()) bad("header field 'v' (protocol version) missing");
  if (!v->is_number_integer()) bad("header field 'v' must be an integer");
  if (v->get<std::int64_t>() != kProtocolVersion)
    throw ProtocolError(WireError::VersionMismatch,
                        "protocol version " + v->dump() + " not supported; this side speaks version " +
                            std::to_string(kProtocolVersion));
  return header;
}

const json& field(const json& header, const char* key) {
  const auto it = header.find(key);
  if (it == header.end()) bad(std::string("header field '") + key + "' missing");
  return *it;
}

std::string stringField(const json& header, const char* key) {
  const json& f = field(header, key);
  if (!f.is_string()) bad(std::string("header field '") + key + "' must be a string");
  return f.get<std::string>();
}

double numberField(const json& header, const char* key) {
  const json& f = field(header, key);
  if (!f.is_number()) bad(std::string("header field '") + key + "' must be a number");
  return f.get<double>();
}

std::uint64_t unsignedField(const json& header, const char* key) {
  const json& f = field(header, key);
  if (!f.is_number_unsigned()) bad(std::string("header field '") + key + "' must be a non-negative integer");
  return f.get<std::uint64_t>();
}

std::int32_t int32Field(const json& header, const char* key) {
  const json& f = field(header, key);
  if (!f.is_number_integer()) bad(std::string("header field '") + key + "' must be an integer");
  const auto value = f.get<std::int64_t>();
  if (value < std::numeric_limits<std::int32_t>::min() || value > std::numeric_limits<std::int32_t>::max())
    bad(std::string("header field '") + key + "' out of the int32 range");
  return static_cast<std::int32_t>(value);
}

// Count field used to size an array of `per_item` elements of `element_bytes`: bounded so the
// multiplication cannot overflow and the frame limit holds.
std::size_t countField(const json& header, const char* key, std::size_t per_item, std::size_t element_bytes) {
  const std::uint64_t n = unsignedField(header, key);
  if (n > kMaxFrameBytes / (per_item * element_bytes))
    bad(std::string("header field '") + key + "' = " + std::to_string(n) + " exceeds the frame size limit");
  return static_cast<std::size_t>(n);
}

void expectFrames(const Multipart& message, std::size_t count, const std::string& op) {
  if (message.size() != count)
    bad("'" + op + "' carries " + std::to_string(count - 1) + " array frame(s), got " +
        std::to_string(message.size() - 1));
}

template <class T>
Frame arrayFrame(const T* data, std::size_t count) {
  Frame f(count * sizeof(T), '\0');
  if (count) std::memcpy(f.data(), data, f.size());
  return f;
}

std::vector<double> floats(const Frame& f, std::size_t count, const std::string& what) {
  if (f.size() != count * sizeof(double))
    bad(what + ": frame has " + std::to_string(f.size()) + " bytes, expected " +
        std::to_string(count * sizeof(double)) + " (" + std::to_string(count) + " float64)");
  std::vector<double> values(count);
  if (count) std::memcpy(values.data(), f.data(), f.size());
  for (std::size_t i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) bad(what + ": value " + std::to_string(i) + " is not finite");
  return values;
}

Frame motionFrame(const RigidMotionData& m) {
  const double v[7] = {m.origin_m[0], m.origin_m[1], m.origin_m[2], m.velocity_m_s[0],
                       m.velocity_m_s[1], m.velocity_m_s[2], m.t0_s};
  return arrayFrame(v, 7);
}

RigidMotionData motionFrom(const Frame& f) {
  const auto v = floats(f, 7, "rigid motion (origin_m[3], velocity_m_s[3], t0_s)");
  return {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, v[6]};
}

json baseHeader(const std::string& op, std::uint64_t seq) {
  return json{{"v", kProtocolVersion}, {"op", op}, {"seq", seq}};
}

std::size_t xyzCount(const std::vector<double>& xyz, const char* what) {
  if (xyz.size() % 3 != 0)
    throw std::invalid_argument(std::string(what) + ": array size " + std::to_string(xyz.size()) +
                                " is not a multiple of 3");
  return xyz.size() / 3;
}

// ---- request encoding / decoding per operation ----
void encodeBody(const Hello& r, json& h, Multipart&) {
  h["protocol_version"] = r.protocol_version;
  h["client"] = r.client;
}
void encodeBody(const ListGeometries&, json&, Multipart&) {}
void encodeBody(const GetTime&, json&, Multipart&) {}
void encodeBody(const GetNodePositions& r, json& h, Multipart&) { h["geometry"] = r.geometry; }
const char* modeName(ForceMode mode) { return mode == ForceMode::IntervalMean ? "interval_mean" : "instantaneous"; }

ForceMode modeField(const json& h) {
  const std::string mode = stringField(h, "mode");
  if (mode != "interval_mean" && mode != "instantaneous")
    bad("header field 'mode' must be \"interval_mean\" or \"instantaneous\", got \"" + mode + "\"");
  return mode == "interval_mean" ? ForceMode::IntervalMean : ForceMode::Instantaneous;
}

double durationField(const json& h) {
  const double d = numberField(h, "duration_s");
  if (!(d >= 0) || !std::isfinite(d)) bad("header field 'duration_s' must be finite and >= 0");
  return d;
}

void encodeBody(const GetNodeForces& r, json& h, Multipart&) {
  h["geometry"] = r.geometry;
  h["mode"] = modeName(r.mode);
}
void encodeBody(const SetNodePositions& r, json& h, Multipart& m) {
  h["geometry"] = r.geometry;
  h["n"] = xyzCount(r.xyz, "set_node_positions");
  m.push_back(arrayFrame(r.xyz.data(), r.xyz.size()));
}
void encodeBody(const Simulate& r, json& h, Multipart&) { h["duration_s"] = r.duration_s; }
void encodeBody(const Advance& r, json& h, Multipart& m) {
  h["geometry"] = r.geometry;
  h["n"] = xyzCount(r.xyz, "advance");
  h["duration_s"] = r.duration_s;
  h["mode"] = modeName(r.mode);
  m.push_back(arrayFrame(r.xyz.data(), r.xyz.size()));
}
void encodeBody(const GetRigidMotion& r, json& h, Multipart&) { h["geometry"] = r.geometry; }
void encodeBody(const SetRigidMotion& r, json& h, Multipart& m) {
  h["geometry"] = r.geometry;
  m.push_back(motionFrame(r.motion));
}
void encodeBody(const Checkpoint& r, json& h, Multipart&) { h["name"] = r.name; }
void encodeBody(const Restore& r, json& h, Multipart&) { h["name"] = r.name; }
void encodeBody(const Shutdown&, json&, Multipart&) {}

std::string checkpointNameField(const json& header) {
  const std::string name = stringField(header, "name");
  if (!isCheckpointName(name))
    bad("header field 'name' must be a checkpoint name: 1 to " + std::to_string(kMaxCheckpointNameBytes) +
        " characters of A-Z a-z 0-9 . _ -, not starting with '.' (a name, never a path)");
  return name;
}

// An optional string field: empty when absent.
std::string optionalString(const json& header, const char* key) {
  return header.contains(key) ? stringField(header, key) : std::string();
}

RequestBody decodeBody(const std::string& op, const json& h, const Multipart& m) {
  const auto noFrames = [&] { expectFrames(m, 1, op); };
  if (op == "hello") {
    noFrames();
    return Hello{int32Field(h, "protocol_version"), stringField(h, "client")};
  }
  if (op == "list_geometries") return noFrames(), ListGeometries{};
  if (op == "get_time") return noFrames(), GetTime{};
  if (op == "get_node_positions") return noFrames(), GetNodePositions{stringField(h, "geometry")};
  if (op == "get_node_forces") return noFrames(), GetNodeForces{stringField(h, "geometry"), modeField(h)};
  if (op == "set_node_positions") {
    expectFrames(m, 2, op);
    const std::size_t n = countField(h, "n", 3, sizeof(double));
    return SetNodePositions{stringField(h, "geometry"), floats(m[1], 3 * n, "set_node_positions xyz")};
  }
  if (op == "simulate") return noFrames(), Simulate{durationField(h)};
  if (op == "advance") {
    expectFrames(m, 2, op);
    const std::size_t n = countField(h, "n", 3, sizeof(double));
    return Advance{stringField(h, "geometry"), floats(m[1], 3 * n, "advance xyz"), durationField(h), modeField(h)};
  }
  if (op == "get_rigid_motion") return noFrames(), GetRigidMotion{stringField(h, "geometry")};
  if (op == "set_rigid_motion") {
    expectFrames(m, 2, op);
    return SetRigidMotion{stringField(h, "geometry"), motionFrom(m[1])};
  }
  if (op == "checkpoint") return noFrames(), Checkpoint{checkpointNameField(h)};
  if (op == "restore") return noFrames(), Restore{checkpointNameField(h)};
  if (op == "shutdown") return noFrames(), Shutdown{};
  bad("unknown operation '" + op + "'");
}

// ---- replies ----
enum class ReplyKind { Hello, Geometries, Time, Advance, NodeArray, RigidMotion, Ack };

ReplyKind replyKindFor(const std::string& op) {
  if (op == "hello") return ReplyKind::Hello;
  if (op == "list_geometries") return ReplyKind::Geometries;
  if (op == "get_time" || op == "simulate") return ReplyKind::Time;
  if (op == "advance") return ReplyKind::Advance;
  if (op == "get_node_positions" || op == "get_node_forces") return ReplyKind::NodeArray;
  if (op == "get_rigid_motion") return ReplyKind::RigidMotion;
  if (op == "set_node_positions" || op == "set_rigid_motion" || op == "checkpoint" || op == "restore" ||
      op == "shutdown")
    return ReplyKind::Ack;
  bad("reply to unknown operation '" + op + "'");
}

constexpr ReplyKind kindOf(const HelloReply&) { return ReplyKind::Hello; }
constexpr ReplyKind kindOf(const GeometriesReply&) { return ReplyKind::Geometries; }
constexpr ReplyKind kindOf(const TimeReply&) { return ReplyKind::Time; }
constexpr ReplyKind kindOf(const AdvanceReply&) { return ReplyKind::Advance; }
constexpr ReplyKind kindOf(const NodeArrayReply&) { return ReplyKind::NodeArray; }
constexpr ReplyKind kindOf(const RigidMotionReply&) { return ReplyKind::RigidMotion; }
constexpr ReplyKind kindOf(const Ack&) { return ReplyKind::Ack; }

void encodeBody(const HelloReply& r, json& h, Multipart&) {
  h["protocol_version"] = r.protocol_version;
  h["backend"] = r.backend;
  h["backend_version"] = r.backend_version;
  h["dem_time_step_s"] = r.dem_time_step_s;
  if (!r.soil_json.empty()) {
    json soil = json::parse(r.soil_json, nullptr, false);
    if (!soil.is_object()) bad("hello reply: soil must be the text of a JSON object");
    h["soil"] = std::move(soil);
  }
  if (!r.session.empty()) h["session"] = r.session;
  if (r.max_simulate_s > 0) h["max_simulate_s"] = r.max_simulate_s;
  if (r.advance) h["advance"] = true;
}
void encodeBody(const GeometriesReply& r, json& h, Multipart& m) {
  json list = json::array();
  for (const auto& g : r.geometries) {
    list.push_back({{"name", g.name}, {"node_count", g.node_count}, {"triangle_count", g.triangles.size()}});
    m.push_back(arrayFrame(g.triangles.empty() ? nullptr : g.triangles.front().data(), 3 * g.triangles.size()));
  }
  h["geometries"] = std::move(list);
}
void encodeBody(const TimeReply& r, json& h, Multipart&) { h["time_s"] = r.time_s; }
void encodeBody(const AdvanceReply& r, json& h, Multipart& m) {
  h["time_s"] = r.time_s;
  h["geometry"] = r.geometry;
  h["n"] = xyzCount(r.forces, "advance reply");
  m.push_back(arrayFrame(r.forces.data(), r.forces.size()));
}
void encodeBody(const NodeArrayReply& r, json& h, Multipart& m) {
  h["geometry"] = r.geometry;
  h["n"] = xyzCount(r.xyz, "node array reply");
  m.push_back(arrayFrame(r.xyz.data(), r.xyz.size()));
}
void encodeBody(const RigidMotionReply& r, json&, Multipart& m) { m.push_back(motionFrame(r.motion)); }
void encodeBody(const Ack&, json&, Multipart&) {}

ReplyBody decodeReplyBody(const std::string& op, const json& h, const Multipart& m) {
  switch (replyKindFor(op)) {
    case ReplyKind::Hello: {
      expectFrames(m, 1, op);
      const double dt = numberField(h, "dem_time_step_s");
      const double max_simulate = h.contains("max_simulate_s") ? numberField(h, "max_simulate_s") : 0.0;
      std::string soil;
      if (h.contains("soil")) {
        if (!h["soil"].is_object()) bad("header field 'soil' must be an object");
        soil = h["soil"].dump();
      }
      HelloReply reply{int32Field(h, "protocol_version"), stringField(h, "backend"),
                       stringField(h, "backend_version"), dt, optionalString(h, "session"), max_simulate};
      reply.soil_json = std::move(soil);
      if (h.contains("advance")) {
        if (!h["advance"].is_boolean()) bad("header field 'advance' must be a boolean");
        reply.advance = h["advance"].get<bool>();
      }
      return reply;
    }
    case ReplyKind::Geometries: {
      const json& list = field(h, "geometries");
      if (!list.is_array()) bad("header field 'geometries' must be an array");
      expectFrames(m, 1 + list.size(), op);
      GeometriesReply reply;
      for (std::size_t i = 0; i < list.size(); ++i) {
        const json& g = list[i];
        if (!g.is_object()) bad("geometries[" + std::to_string(i) + "] must be an object");
        GeometryEntry entry{stringField(g, "name"), int32Field(g, "node_count"), {}};
        if (entry.node_count < 0) bad("geometries[" + std::to_string(i) + "].node_count is negative");
        const std::size_t nt = countField(g, "triangle_count", 3, sizeof(std::int32_t));
        const Frame& f = m[1 + i];
        if (f.size() != nt * 3 * sizeof(std::int32_t))
          bad("triangle frame of geometry '" + entry.name + "' has " + std::to_string(f.size()) +
              " bytes, expected " + std::to_string(nt * 3 * sizeof(std::int32_t)));
        entry.triangles.resize(nt);
        if (nt) std::memcpy(entry.triangles.data(), f.data(), f.size());
        for (const auto& t : entry.triangles)
          for (const auto id : t)
            if (id < 0 || id >= entry.node_count)
              bad("geometry '" + entry.name + "': triangle node id " + std::to_string(id) + " outside 0.." +
                  std::to_string(entry.node_count - 1));
        reply.geometries.push_back(std::move(entry));
      }
      return reply;
    }
    case ReplyKind::Time:
      expectFrames(m, 1, op);
      return TimeReply{numberField(h, "time_s")};
    case ReplyKind::Advance: {
      expectFrames(m, 2, op);
      const std::size_t n = countField(h, "n", 3, sizeof(double));
      return AdvanceReply{numberField(h, "time_s"), stringField(h, "geometry"), floats(m[1], 3 * n, op + " reply")};
    }
    case ReplyKind::NodeArray: {
      expectFrames(m, 2, op);
      const std::size_t n = countField(h, "n", 3, sizeof(double));
      return NodeArrayReply{stringField(h, "geometry"), floats(m[1], 3 * n, op + " reply")};
    }
    case ReplyKind::RigidMotion:
      expectFrames(m, 2, op);
      return RigidMotionReply{motionFrom(m[1])};
    case ReplyKind::Ack:
      expectFrames(m, 1, op);
      return Ack{};
  }
  bad("unhandled reply kind");
}

}  // namespace

bool isCheckpointName(const std::string& name) {
  if (name.empty() || name.size() > kMaxCheckpointNameBytes || name[0] == '.') return false;
  return std::all_of(name.begin(), name.end(), [](unsigned char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
  });
}

std::string opName(const RequestBody& body) {
  return std::visit([](const auto& r) { return std::string(OpTag<std::decay_t<decltype(r)>>::name); }, body);
}

Multipart encode(const Request& request) {
  const std::string op = opName(request.body);
  json header = baseHeader(op, request.seq);
  if (!request.session.empty()) header["session"] = request.session;
  Multipart message(1);
  std::visit([&](const auto& r) { encodeBody(r, header, message); }, request.body);
  message[0] = dumpHeader(header);
  return message;
}

Multipart encode(const Reply& reply) {
  json header = baseHeader(reply.op, reply.seq);
  Multipart message(1);
  std::visit(
      [&](const auto& r) {
        using T = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<T, ErrorReply>) {
          header["error"] = {{"code", static_cast<std::int32_t>(r.code)}, {"message", r.message}};
        } else {
          if (replyKindFor(reply.op) != kindOf(r))
            throw std::invalid_argument("reply body does not answer operation '" + reply.op + "'");
          encodeBody(r, header, message);
        }
      },
      reply.body);
  message[0] = dumpHeader(header);
  return message;
}

Request decodeRequest(const Multipart& message) {
  const json header = parseHeader(message);
  Request request;
  request.seq = unsignedField(header, "seq");
  request.session = optionalString(header, "session");
  request.body = decodeBody(stringField(header, "op"), header, message);
  return request;
}

Reply decodeReply(const Multipart& message) {
  const json header = parseHeader(message);
  Reply reply;
  reply.seq = unsignedField(header, "seq");
  reply.op = stringField(header, "op");
  if (const auto e = header.find("error"); e != header.end()) {
    if (!e->is_object()) bad("header field 'error' must be an object");
    const std::int32_t code = int32Field(*e, "code");
    if (code < 1 || code > kLastWireError)
      bad("error code " + std::to_string(code) + " is not a protocol error code");
    expectFrames(message, 1, "error");
    reply.body = ErrorReply{static_cast<WireError>(code), stringField(*e, "message")};
    return reply;
  }
  reply.body = decodeReplyBody(reply.op, header, message);
  return reply;
}

Reply errorReplyFor(const Multipart& request, WireError code, const std::string& message) {
  Reply reply{0, "error", ErrorReply{code, message}};
  if (request.empty() || request[0].size() > kMaxHeaderBytes) return reply;
  const json header = json::parse(request[0], nullptr, false);
  if (header.is_discarded() || !header.is_object()) return reply;
  if (const auto s = header.find("seq"); s != header.end() && s->is_number_unsigned()) reply.seq = s->get<std::uint64_t>();
  if (const auto o = header.find("op"); o != header.end() && o->is_string()) reply.op = o->get<std::string>();
  return reply;
}

}  // namespace demfem::protocol
