#include "demfem/adapter/checkpoint_file.hpp"
#include "demfem/adapter/server.hpp"
#include "demfem/adapter/test_backends.hpp"
#include "../protocol/fuzz_input.hpp"

#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

using namespace demfem::adapter;
using namespace std::chrono_literals;
namespace p = demfem::protocol;
namespace fs = std::filesystem;

namespace {

const p::PeerAddress kOwner{"owner", true}, kOther{"intruder", true};

// One request from `from` at `now` (default: the server's clock).
p::Reply ask(Server& server, const p::Request& request, const p::PeerAddress& from = kOwner,
             Server::Clock::time_point now = Server::Clock::now()) {
  return p::decodeReply(server.handle(from, p::encode(request), now));
}

p::WireError errorCode(const p::Reply& reply) {
  const auto* e = std::get_if<p::ErrorReply>(&reply.body);
  return e ? e->code : p::WireError::Internal;
}

std::string errorText(const p::Reply& reply) {
  const auto* e = std::get_if<p::ErrorReply>(&reply.body);
  return e ? e->message : std::string();
}

std::unique_ptr<CouplingApi> backend() { return makeTestBackend("harmonic", {demfem::study::Tool{}}, TestLoad{}); }

// Says hello as `from` and returns the session token.
std::string hello(Server& server, std::uint64_t seq, const p::PeerAddress& from = kOwner,
                  Server::Clock::time_point now = Server::Clock::now()) {
  const p::Reply reply = ask(server, {seq, p::Hello{1, "test"}}, from, now);
  REQUIRE(std::holds_alternative<p::HelloReply>(reply.body));
  return std::get<p::HelloReply>(reply.body).session;
}


}  // namespace

TEST_CASE("server: the session starts with hello, and seq must increase", "[adapter]") {
  auto api = backend();
  Server server(*api);
  CHECK(errorCode(ask(server, {1, p::GetTime{}})) == p::WireError::BadRequest);
  CHECK(errorCode(ask(server, {1, p::Hello{2, "future client"}})) == p::WireError::VersionMismatch);
  const p::Reply reply = ask(server, {2, p::Hello{1, "test"}});
  REQUIRE(std::holds_alternative<p::HelloReply>(reply.body));
  const auto& h = std::get<p::HelloReply>(reply.body);
  CHECK(h.backend == "harmonic");
  CHECK(h.session.size() == 32);  // 128 random bits in hex
  CHECK(h.max_simulate_s == demfem::study::kDefaultMaxSimulateS);
  CHECK(reply.seq == 2);
  CHECK(std::holds_alternative<p::TimeReply>(ask(server, {3, p::GetTime{}, h.session}).body));
  const p::Reply replay = ask(server, {3, p::GetTime{}, h.session});
  CHECK(errorCode(replay) == p::WireError::BadRequest);
  CHECK_THAT(errorText(replay), Catch::Contains("out of order"));
  CHECK(std::holds_alternative<p::Ack>(ask(server, {10, p::Shutdown{}, h.session}).body));
  CHECK(server.shutdownDone());
  CHECK(errorCode(ask(server, {11, p::GetTime{}, h.session})) == p::WireError::BadRequest);
}

TEST_CASE("server: another connection gets busy and cannot disturb the owner's session", "[adapter]") {
  auto api = backend();
  Server server(*api);
  const std::string token = hello(server, 1);
  // Another connection: refused whatever it sends, even the owner's token or a huge seq.
  CHECK(errorCode(ask(server, {1, p::Hello{1, "second client"}}, kOther)) == p::WireError::Busy);
  CHECK(errorCode(ask(server, {1000, p::Simulate{1e-3}}, kOther)) == p::WireError::Busy);
  CHECK(errorCode(ask(server, {1001, p::Shutdown{}, token}, kOther)) == p::WireError::Busy);
  CHECK_THAT(errorText(ask(server, {1002, p::GetTime{}, token}, kOther)), Catch::Contains("busy"));
  // The owner without its token is refused too.
  CHECK(errorCode(ask(server, {2, p::GetTime{}}, kOwner)) == p::WireError::Busy);
  // Nothing of that changed the owner's session: seq 2 is next, time is still 0.
  const p::Reply time = ask(server, {2, p::GetTime{}, token});
  REQUIRE(std::holds_alternative<p::TimeReply>(time.body));
  CHECK(std::get<p::TimeReply>(time.body).time_s == 0.0);
  CHECK_FALSE(server.shutdownDone());
}

TEST_CASE("server: a hello with seq 2^64-1 locks nobody out", "[adapter]") {
  auto api = backend();
  ServerOptions options;
  options.idle_timeout = 1s;
  Server server(*api, options);
  const auto t0 = Server::Clock::now();
  const std::uint64_t top = std::numeric_limits<std::uint64_t>::max();
  const std::string first = hello(server, top, kOwner, t0);
  CHECK(errorCode(ask(server, {top, p::GetTime{}, first}, kOwner, t0)) == p::WireError::BadRequest);
  // Its owner starts over with a new hello (sequence numbers are per session).
  const std::string second = hello(server, 1, kOwner, t0);
  CHECK(second != first);
  CHECK(std::holds_alternative<p::TimeReply>(ask(server, {2, p::GetTime{}, second}, kOwner, t0).body));
  // Refusals of another connection do not keep the session alive ...
  CHECK(errorCode(ask(server, {1, p::Hello{1, "x"}}, kOther, t0 + 600ms)) == p::WireError::Busy);
  CHECK(errorCode(ask(server, {1, p::Hello{1, "x"}}, kOther, t0 + 900ms)) == p::WireError::Busy);
  CHECK(server.sessionOpen(t0 + 900ms));
  CHECK_FALSE(server.sessionOpen(t0 + 1100ms));
  // ... so once the owner has been silent for the idle timeout, a new client is served.
  const std::string third = hello(server, top, kOther, t0 + 1100ms);
  CHECK(errorCode(ask(server, {3, p::GetTime{}, second}, kOwner, t0 + 1200ms)) == p::WireError::Busy);
  // A new owner stuck at seq 2^64-1 starts over with hello and can always shut the server down.
  CHECK(errorCode(ask(server, {top, p::Shutdown{}, third}, kOther, t0 + 1200ms)) == p::WireError::BadRequest);
  const std::string fourth = hello(server, 1, kOther, t0 + 1200ms);
  CHECK(std::holds_alternative<p::Ack>(ask(server, {2, p::Shutdown{}, fourth}, kOther, t0 + 1200ms).body));
  CHECK(server.shutdownDone());
}

TEST_CASE("server: simulate beyond the stated limit is refused and nothing is simulated", "[adapter]") {
  auto api = backend();
  ServerOptions options;
  options.max_simulate_s = 0.5;
  Server server(*api, options);
  const std::string token = hello(server, 1);
  std::uint64_t seq = 2;
  for (const double duration : {0.6, 1e20, std::numeric_limits<double>::max()}) {
    INFO("duration " << duration);
    const p::Reply r = ask(server, {seq++, p::Simulate{duration}, token});
    CHECK(errorCode(r) == p::WireError::BadRequest);
    CHECK_THAT(errorText(r), Catch::Contains("limit"));
  }
  const p::Reply advance = ask(server, {seq++, p::Advance{"tool", {}, 0.6, p::ForceMode::IntervalMean}, token});
  CHECK(errorCode(advance) == p::WireError::BadRequest);
  CHECK_THAT(errorText(advance), Catch::Contains("limit"));
  CHECK(api->time() == 0.0);
  const p::Reply ok = ask(server, {seq++, p::Simulate{0.5}, token});
  REQUIRE(std::holds_alternative<p::TimeReply>(ok.body));
  CHECK(std::get<p::TimeReply>(ok.body).time_s == Approx(0.5).epsilon(1e-12));
}

TEST_CASE("server: node positions beyond 1 km or not a number are refused and nothing moves", "[adapter]") {
  auto api = backend();
  Server server(*api, ServerOptions{});
  const std::string token = hello(server, 1);
  std::uint64_t seq = 2;
  const NodeArray before = api->nodePositions("tool");
  REQUIRE(before.size() >= 3);
  for (const double bad : {1e300, -2e3, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    INFO("coordinate " << bad);
    NodeArray xyz = before;
    xyz[xyz.size() - 2] = bad;
    const p::Reply set = ask(server, {seq++, p::SetNodePositions{"tool", xyz}, token});
    CHECK(errorCode(set) == p::WireError::BadRequest);
    // The codec already refuses a value that is not finite; the server the finite ones out of range.
    CHECK_THAT(errorText(set), Catch::Contains(std::isfinite(bad) ? "coordinate y" : "not finite"));
    const p::Reply advance = ask(server, {seq++, p::Advance{"tool", xyz, 0.001, p::ForceMode::IntervalMean}, token});
    CHECK(errorCode(advance) == p::WireError::BadRequest);
  }
  CHECK(api->nodePositions("tool") == before);
  CHECK(api->time() == 0.0);
}

TEST_CASE("the test backends refuse a simulate that would wrap their time", "[adapter]") {
  auto api = backend();  // dt = 1e-5 s: 2^53 steps are 9e10 s
  for (const double duration : {1e20, 1e11, std::numeric_limits<double>::infinity()}) {
    INFO("duration " << duration);
    CHECK_THROWS_AS(api->simulate(duration), CouplingError);
    CHECK(api->time() == 0.0);
  }
  api->simulate(1e10);
  CHECK(api->time() == Approx(1e10).epsilon(1e-12));
  CHECK_THROWS_WITH(api->simulate(8.5e10), Catch::Contains("steps"));  // alone below 2^53 steps, not on top
  CHECK(api->time() == Approx(1e10).epsilon(1e-12));
}

TEST_CASE("server: checkpoints are names in the server's own directory, never paths", "[adapter]") {
  const fs::path dir = demfem::support::freshDir("server-ckpt");
  auto api = backend();
  ServerOptions options;
  options.checkpoint_dir = dir / "checkpoints";
  fs::create_directories(options.checkpoint_dir);
  std::vector<std::string> logged;
  options.log = [&](const std::string& text) { logged.push_back(text); };
  Server server(*api, options);
  const std::string token = hello(server, 1);
  std::uint64_t seq = 2;
  { std::ofstream(dir / "precious.txt") << "keep me\n"; }
  for (const std::string& name : std::vector<std::string>{"../precious.txt", (dir / "precious.txt").string(), "..", ".hidden", "a/b", ""}) {
    INFO("name '" << name << "'");
    CHECK(errorCode(ask(server, {seq++, p::Checkpoint{name}, token})) == p::WireError::BadRequest);
  }
  CHECK(fs::file_size(dir / "precious.txt") == 8);
  REQUIRE(std::holds_alternative<p::Ack>(ask(server, {seq++, p::Checkpoint{"good.ckpt"}, token}).body));
  CHECK(fs::exists(options.checkpoint_dir / "good.ckpt"));
  // A missing file and an invalid one get the same answer: a peer learns nothing about the disk.
  { std::ofstream(options.checkpoint_dir / "garbage.ckpt") << "not a checkpoint"; }
  const std::string missing = errorText(ask(server, {seq++, p::Restore{"missing.ckpt"}, token}));
  const std::string garbage = errorText(ask(server, {seq++, p::Restore{"garbage.ckpt"}, token}));
  CHECK(missing.substr(missing.find("' failed")) == garbage.substr(garbage.find("' failed")));
  CHECK(missing.find(dir.string()) == std::string::npos);
  CHECK(logged.size() >= 2);  // the causes went to the server's log
  // Without a directory the server keeps no checkpoints.
  auto other = backend();
  Server plain(*other);
  const std::string t = hello(plain, 1);
  CHECK(errorCode(ask(plain, {2, p::Checkpoint{"x.ckpt"}, t})) == p::WireError::Unsupported);
  fs::remove_all(dir);
}

TEST_CASE("a corrupted or truncated checkpoint is refused and leaves the backend as it was", "[adapter]") {
  const fs::path dir = demfem::support::freshDir("server-corrupt");
  auto api = backend();
  api->simulate(0.01);
  NodeArray moved = api->nodePositions("tool");
  moved[2] += 1e-3;
  api->setNodePositions("tool", moved);
  const fs::path file = dir / "state.ckpt";
  api->checkpoint(file);
  api->simulate(0.02);
  moved[5] -= 2e-3;
  api->setNodePositions("tool", moved);
  const double time = api->time();
  const NodeArray positions = api->nodePositions("tool"), forces = api->nodeForces("tool");
  std::string image;
  {
    std::ifstream in(file, std::ios::binary);
    image.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto unchanged = [&] {
    CHECK(api->time() == time);
    CHECK(api->nodePositions("tool") == positions);
    CHECK(api->nodeForces("tool") == forces);
  };
  std::mt19937 rng(5);
  const auto write = [&](const std::string& bytes) { std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes; };
  SECTION("flipped bytes") {
    for (int trial = 0; trial < 20; ++trial) {
      std::string bad = image;
      for (int k = 0; k < 1 + trial * 10; ++k) bad[rng() % bad.size()] ^= static_cast<char>(1 + rng() % 255);
      write(bad);
      CHECK_THROWS_AS(api->restore(file), CouplingError);
      unchanged();
    }
  }
  SECTION("truncated, extended, another kind") {
    for (const std::size_t keep : {std::size_t{0}, std::size_t{7}, kCheckpointHeaderBytes, image.size() / 2, image.size() - 1}) {
      write(image.substr(0, keep));
      CHECK_THROWS_AS(api->restore(file), CouplingError);
      unchanged();
    }
    write(image + "x");
    CHECK_THROWS_WITH(api->restore(file), Catch::Contains("payload"));
    unchanged();
    auto spring = makeTestBackend("spring", {demfem::study::Tool{}}, TestLoad{});
    spring->checkpoint(file);
    CHECK_THROWS_WITH(api->restore(file), Catch::Contains("another backend"));
    unchanged();
  }
  SECTION("a valid checksum over inconsistent content") {
    const std::string payload = checkpointPayload(image, "test-harmonic", "image");
    write(checkpointImage("test-harmonic", payload.substr(0, payload.size() - 8)));
    CHECK_THROWS_WITH(api->restore(file), Catch::Contains("inconsistent"));
    unchanged();
  }
  SECTION("the intact file restores") {
    write(image);
    api->restore(file);
    CHECK(api->time() == Approx(0.01).epsilon(1e-12));
  }
  fs::remove_all(dir);
}

TEST_CASE("server: malformed and wrong-version messages get error replies echoing seq and op", "[adapter]") {
  auto api = backend();
  Server server(*api);
  hello(server, 1);
  const p::Reply garbage = p::decodeReply(server.handle(kOwner, {"not json at all"}));
  CHECK(errorCode(garbage) == p::WireError::BadRequest);
  const p::Reply v2 = p::decodeReply(server.handle(kOwner, {R"({"v":2,"op":"get_time","seq":5})"}));
  CHECK(errorCode(v2) == p::WireError::VersionMismatch);
  CHECK(v2.seq == 5);
  CHECK(v2.op == "get_time");
  CHECK(errorCode(p::decodeReply(server.handle(kOwner, {}))) == p::WireError::BadRequest);
}

TEST_CASE("server: backend errors come back as error replies with the API's codes", "[adapter]") {
  auto api = backend();
  Server server(*api);
  const std::string token = hello(server, 1);
  CHECK(errorCode(ask(server, {2, p::GetNodeForces{"plough", p::ForceMode::IntervalMean}, token})) ==
        p::WireError::UnknownGeometry);
  CHECK(errorCode(ask(server, {3, p::SetNodePositions{"tool", {0, 0, 0}}, token})) == p::WireError::SizeMismatch);
  CHECK(errorCode(ask(server, {4, p::Advance{"tool", {0, 0, 0}, 1e-4, p::ForceMode::IntervalMean}, token})) ==
        p::WireError::SizeMismatch);
  CHECK(api->time() == 0.0);  // the advance stopped at its positions
  // A failed request does not advance the session: the next one is served normally.
  CHECK(std::holds_alternative<p::NodeArrayReply>(ask(server, {5, p::GetNodePositions{"tool"}, token}).body));
}

TEST_CASE("server fuzz: 1e5 random and mutated requests from two connections always get a decodable reply",
          "[adapter]") {
  auto api = backend();
  Server server(*api);
  const std::string token = hello(server, 1);
  const std::vector<p::Request> seeds{
      {2, p::GetNodeForces{"tool", p::ForceMode::IntervalMean}, token}, {3, p::Simulate{1e-4}, token},
      {4, p::SetNodePositions{"tool", api->nodePositions("tool")}, token}, {5, p::GetRigidMotion{"tool"}, token},
      {6, p::SetRigidMotion{"tool", {}}, token}, {7, p::ListGeometries{}, token}, {8, p::Hello{1, "again"}},
      {9, p::Advance{"tool", api->nodePositions("tool"), 1e-4, p::ForceMode::Instantaneous}, token}};
  std::vector<p::Multipart> wire;
  for (const auto& s : seeds) wire.push_back(p::encode(s));
  p::fuzz::Mutator mutator(99);
  std::size_t errors = 0, busy = 0;
  for (int i = 0; i < 100000; ++i) {
    const p::Multipart in = i % 3 == 0 ? mutator.random() : mutator.mutate(wire[static_cast<std::size_t>(i) % wire.size()]);
    const p::PeerAddress& from = i % 5 == 0 ? kOther : kOwner;
    const p::Reply reply = p::decodeReply(server.handle(from, in));  // throws (fails the test) if not decodable
    errors += std::holds_alternative<p::ErrorReply>(reply.body);
    busy += errorCode(reply) == p::WireError::Busy;
  }
  CHECK(errors > 50000);
  CHECK(busy > 1000);
  CHECK_FALSE(server.shutdownDone());  // shutdown was not among the seeds
}
