#include "demfem/adapter/server.hpp"
#include "demfem/adapter/test_backends.hpp"
#include "../protocol/fuzz_input.hpp"

#include <catch2/catch.hpp>

using namespace demfem::adapter;
namespace p = demfem::protocol;

namespace {

p::Reply ask(Server& server, const p::Request& request) { return p::decodeReply(server.handle(p::encode(request))); }

p::WireError errorCode(const p::Reply& reply) {
  const auto* e = std::get_if<p::ErrorReply>(&reply.body);
  return e ? e->code : p::WireError::Internal;
}

std::unique_ptr<CouplingApi> backend() { return makeTestBackend("harmonic", {demfem::study::Tool{}}, TestLoad{}); }

}  // namespace

TEST_CASE("server: the session starts with hello, and seq must increase", "[adapter]") {
  auto api = backend();
  Server server(*api);
  CHECK(errorCode(ask(server, {1, p::GetTime{}})) == p::WireError::BadRequest);
  CHECK(errorCode(ask(server, {1, p::Hello{2, "future client"}})) == p::WireError::VersionMismatch);
  const p::Reply hello = ask(server, {2, p::Hello{1, "test"}});
  REQUIRE(std::holds_alternative<p::HelloReply>(hello.body));
  CHECK(std::get<p::HelloReply>(hello.body).backend == "harmonic");
  CHECK(hello.seq == 2);
  CHECK(std::holds_alternative<p::TimeReply>(ask(server, {3, p::GetTime{}}).body));
  const p::Reply replay = ask(server, {3, p::GetTime{}});
  CHECK(errorCode(replay) == p::WireError::BadRequest);
  CHECK_THAT(std::get<p::ErrorReply>(replay.body).message, Catch::Contains("out of order"));
  CHECK(std::holds_alternative<p::Ack>(ask(server, {10, p::Shutdown{}}).body));
  CHECK(server.shutdownDone());
  CHECK(errorCode(ask(server, {11, p::GetTime{}})) == p::WireError::BadRequest);
}

TEST_CASE("server: backend errors come back as error replies with the API's codes", "[adapter]") {
  auto api = backend();
  Server server(*api);
  ask(server, {1, p::Hello{}});
  CHECK(errorCode(ask(server, {2, p::GetNodeForces{"plough", p::ForceMode::IntervalMean}})) ==
        p::WireError::UnknownGeometry);
  CHECK(errorCode(ask(server, {3, p::SetNodePositions{"tool", {0, 0, 0}}})) == p::WireError::SizeMismatch);
  // A failed request does not advance the session: the next one is served normally.
  CHECK(std::holds_alternative<p::NodeArrayReply>(ask(server, {4, p::GetNodePositions{"tool"}}).body));
}

TEST_CASE("server: malformed and wrong-version messages get error replies echoing seq and op", "[adapter]") {
  auto api = backend();
  Server server(*api);
  ask(server, {1, p::Hello{}});
  const p::Reply garbage = p::decodeReply(server.handle({"not json at all"}));
  CHECK(errorCode(garbage) == p::WireError::BadRequest);
  const p::Reply v2 = p::decodeReply(server.handle({R"({"v":2,"op":"get_time","seq":5})"}));
  CHECK(errorCode(v2) == p::WireError::VersionMismatch);
  CHECK(v2.seq == 5);
  CHECK(v2.op == "get_time");
  CHECK(errorCode(p::decodeReply(server.handle({}))) == p::WireError::BadRequest);
}

TEST_CASE("server: 1e5 random and mutated requests always get a decodable reply", "[adapter]") {
  auto api = backend();
  Server server(*api);
  ask(server, {1, p::Hello{}});
  const std::vector<p::Request> seeds{
      {2, p::GetNodeForces{"tool", p::ForceMode::IntervalMean}}, {3, p::Simulate{1e-4}},
      {4, p::SetNodePositions{"tool", api->nodePositions("tool")}}, {5, p::GetRigidMotion{"tool"}},
      {6, p::SetRigidMotion{"tool", {}}}, {7, p::ListGeometries{}}};
  std::vector<p::Multipart> wire;
  for (const auto& s : seeds) wire.push_back(p::encode(s));
  p::fuzz::Mutator mutator(99);
  std::size_t errors = 0;
  for (int i = 0; i < 100000; ++i) {
    const p::Multipart in = i % 3 == 0 ? mutator.random() : mutator.mutate(wire[static_cast<std::size_t>(i) % wire.size()]);
    const p::Reply reply = p::decodeReply(server.handle(in));  // throws (fails the test) if not decodable
    errors += std::holds_alternative<p::ErrorReply>(reply.body);
  }
  CHECK(errors > 50000);
  CHECK_FALSE(server.shutdownDone());  // shutdown was not among the seeds
}
