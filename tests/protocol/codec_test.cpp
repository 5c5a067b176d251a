#include "demfem/protocol/codec.hpp"
#include "sample_messages.hpp"

#include <nlohmann/json.hpp>

#include <catch2/catch.hpp>

#include <cstring>
#include <limits>
#include <set>

using namespace demfem::protocol;
using nlohmann::json;

namespace {

WireError decodeFailure(const Multipart& m) {
  try {
    decodeRequest(m);
  } catch (const ProtocolError& e) {
    return e.code();
  }
  FAIL("request was accepted: " << m[0]);
  return WireError::Internal;
}

Multipart withHeader(Multipart m, const std::function<void(json&)>& edit) {
  json h = json::parse(m[0]);
  edit(h);
  m[0] = h.dump();
  return m;
}

}  // namespace

TEST_CASE("every request round-trips through the codec unchanged", "[protocol]") {
  std::set<std::size_t> kinds;
  for (const auto& request : samples::requests()) {
    const Multipart wire = encode(request);
    CHECK(decodeRequest(wire) == request);
    kinds.insert(request.body.index());
  }
  // A new message type without a sample fails here.
  CHECK(kinds.size() == std::variant_size_v<RequestBody>);
}

TEST_CASE("every reply round-trips through the codec unchanged", "[protocol]") {
  std::set<std::size_t> kinds;
  for (const auto& reply : samples::replies()) {
    CHECK(decodeReply(encode(reply)) == reply);
    kinds.insert(reply.body.index());
  }
  CHECK(kinds.size() == std::variant_size_v<ReplyBody>);
}

TEST_CASE("arrays travel as raw little-endian float64 frames, scalars in the JSON header", "[protocol]") {
  const std::vector<double> xyz{1.0 / 3.0, -0.0, 6.02214076e23};
  const Multipart m = encode(Request{42, SetNodePositions{"tool", xyz}});
  REQUIRE(m.size() == 2);
  const json h = json::parse(m[0]);
  CHECK(h == json{{"v", 1}, {"op", "set_node_positions"}, {"seq", 42}, {"geometry", "tool"}, {"n", 1}});
  REQUIRE(m[1].size() == 24);
  double back[3];
  std::memcpy(back, m[1].data(), 24);
  CHECK(std::memcmp(back, xyz.data(), 24) == 0);  // bit-exact, including the sign of zero
  // Byte 0 of 1.0 in little-endian float64 is the low mantissa byte (0x00), byte 7 is 0x3f.
  const Multipart one = encode(Request{1, SetNodePositions{"tool", {1.0, 1.0, 1.0}}});
  CHECK(static_cast<unsigned char>(one[1][7]) == 0x3f);
  CHECK(static_cast<unsigned char>(one[1][0]) == 0x00);
}

TEST_CASE("truncated and malformed requests are rejected as BadRequest", "[protocol]") {
  const Multipart set = encode(Request{7, SetNodePositions{"tool", {0, 0, 0, 1, 1, 1}}});
  SECTION("no frames") { CHECK(decodeFailure({}) == WireError::BadRequest); }
  SECTION("array frame missing") { CHECK(decodeFailure({set[0]}) == WireError::BadRequest); }
  SECTION("array frame truncated by one byte") {
    Multipart m = set;
    m[1].pop_back();
    CHECK(decodeFailure(m) == WireError::BadRequest);
  }
  SECTION("header truncated") {
    Multipart m = set;
    m[0].resize(m[0].size() / 2);
    CHECK(decodeFailure(m) == WireError::BadRequest);
  }
  SECTION("extra frame") {
    Multipart m = encode(Request{3, GetTime{}});
    m.push_back("x");
    CHECK(decodeFailure(m) == WireError::BadRequest);
  }
  SECTION("header is not an object") { CHECK(decodeFailure({"[1,2,3]"}) == WireError::BadRequest); }
  SECTION("unknown operation") {
    CHECK(decodeFailure(withHeader(encode(Request{3, GetTime{}}), [](json& h) { h["op"] = "explode"; })) ==
          WireError::BadRequest);
  }
  SECTION("non-finite coordinate") {
    Multipart m = set;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::memcpy(m[1].data() + 8, &nan, 8);
    CHECK(decodeFailure(m) == WireError::BadRequest);
  }
  SECTION("negative simulate duration") {
    CHECK(decodeFailure(encode(Request{8, Simulate{-1e-3}})) == WireError::BadRequest);
  }
}

TEST_CASE("wrongly typed header fields are rejected and named in the message", "[protocol]") {
  const Multipart forces = encode(Request{5, GetNodeForces{"tool", ForceMode::IntervalMean}});
  const auto message = [](const Multipart& m) {
    try {
      decodeRequest(m);
    } catch (const ProtocolError& e) {
      CHECK(e.code() == WireError::BadRequest);
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  CHECK_THAT(message(withHeader(forces, [](json& h) { h["geometry"] = 3; })), Catch::Contains("'geometry'"));
  CHECK_THAT(message(withHeader(forces, [](json& h) { h["mode"] = "sometimes"; })), Catch::Contains("'mode'"));
  CHECK_THAT(message(withHeader(forces, [](json& h) { h["seq"] = -4; })), Catch::Contains("'seq'"));
  CHECK_THAT(message(withHeader(forces, [](json& h) { h["seq"] = "5"; })), Catch::Contains("'seq'"));
  CHECK_THAT(message(withHeader(forces, [](json& h) { h.erase("op"); })), Catch::Contains("'op'"));
  CHECK_THAT(message(withHeader(encode(Request{8, Simulate{1.0}}), [](json& h) { h["duration_s"] = "1 s"; })),
             Catch::Contains("'duration_s'"));
  CHECK_THAT(message(withHeader(encode(Request{7, SetNodePositions{"tool", {0, 0, 0}}}), [](json& h) { h["n"] = 2; })),
             Catch::Contains("expected 48"));
}

TEST_CASE("oversized messages are rejected before they are parsed", "[protocol]") {
  SECTION("header above the limit") {
    Multipart m = encode(Request{4, GetNodePositions{std::string(kMaxHeaderBytes, 'g')}});
    CHECK(decodeFailure(m) == WireError::BadRequest);
  }
  SECTION("node count that would overflow the frame size limit") {
    const Multipart m = withHeader(encode(Request{7, SetNodePositions{"tool", {0, 0, 0}}}),
                                   [](json& h) { h["n"] = std::numeric_limits<std::uint64_t>::max() / 8; });
    CHECK(decodeFailure(m) == WireError::BadRequest);
  }
  SECTION("too many frames") {
    Multipart m = encode(Request{3, GetTime{}});
    m.resize(kMaxFrames + 1);
    CHECK(decodeFailure(m) == WireError::BadRequest);
  }
}

TEST_CASE("a message of another protocol version is rejected as VersionMismatch", "[protocol]") {
  for (const auto& request : samples::requests()) {
    const Multipart m = withHeader(encode(request), [](json& h) { h["v"] = 2; });
    CHECK(decodeFailure(m) == WireError::VersionMismatch);
  }
  CHECK(decodeFailure(withHeader(encode(Request{1, GetTime{}}), [](json& h) { h.erase("v"); })) == WireError::BadRequest);
  CHECK(decodeFailure(withHeader(encode(Request{1, GetTime{}}), [](json& h) { h["v"] = "1"; })) == WireError::BadRequest);
}

TEST_CASE("an error reply to an unreadable request keeps what can be read of seq and op", "[protocol]") {
  const Reply r1 = errorReplyFor({R"({"v":9,"op":"simulate","seq":12})"}, WireError::VersionMismatch, "v 9");
  CHECK(r1.seq == 12);
  CHECK(r1.op == "simulate");
  const Reply r2 = errorReplyFor({"\xff\xfe not json"}, WireError::BadRequest, "bad");
  CHECK(r2.seq == 0);
  CHECK(r2.op == "error");
  CHECK(decodeReply(encode(r2)) == r2);
}

TEST_CASE("replies whose triangles name missing nodes are rejected", "[protocol]") {
  const Reply bad{2, "list_geometries", GeometriesReply{{{"tool", 3, {{0, 1, 3}}}}}};
  CHECK_THROWS_AS(decodeReply(encode(bad)), ProtocolError);
}
