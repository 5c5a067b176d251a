#include "demfem/adapter/remote_proxy.hpp"
#include "demfem/adapter/server.hpp"
#include "demfem/adapter/test_backends.hpp"

#include <catch2/catch.hpp>

#include <thread>

using namespace demfem::adapter;
using namespace std::chrono_literals;
namespace p = demfem::protocol;

namespace {

std::unique_ptr<CouplingApi> harmonic() { return makeTestBackend("harmonic", {demfem::study::Tool{}}, TestLoad{}); }

ServerOptions idle(std::chrono::milliseconds timeout) {
  ServerOptions options;
  options.idle_timeout = timeout;
  return options;
}

// A server on its own thread until shutdown or 10 s idle.
struct ServedBackend {
  explicit ServedBackend(demfem::protocol::Context& context, const std::string& endpoint)
      : api(harmonic()), socket(context, endpoint, {.insecure_tcp = true}), server(*api, idle(10s)) {
    thread = std::thread([this] {
      try {
        server.serve(socket, 10s);
      } catch (const CouplingError&) {
      }
    });
  }
  ~ServedBackend() { thread.join(); }
  std::unique_ptr<CouplingApi> api;
  p::ServerSocket socket;
  Server server;
  std::thread thread;
};

// The same sequence of calls on any CouplingApi; returns everything observed.
std::vector<double> exercise(CouplingApi& api) {
  std::vector<double> seen;
  const auto add = [&](const NodeArray& a) { seen.insert(seen.end(), a.begin(), a.end()); };
  seen.push_back(api.info().dem_time_step_s);
  const auto geometries = api.geometries();
  seen.push_back(geometries.at(0).node_count);
  seen.push_back(static_cast<double>(geometries.at(0).triangles.size()));
  api.setRigidMotion("tool", {{0.1, 0.05, 0.0}, {0, 0, 0.03}, 0.0});
  const auto motion = api.rigidMotion("tool");
  seen.push_back(motion.velocity_m_s[2]);
  NodeArray x = api.nodePositions("tool");
  int works = 0;
  for (int step = 0; step < 5; ++step) {
    add(api.nodeForces("tool"));
    add(api.nodeForces("tool", ForceMode::Instantaneous));
    x[2] += 1e-5;
    if (step % 2 == 0) {
      api.setNodePositions("tool", x);
      api.simulate(1e-3);
    } else {  // the same in one exchange, the client's work overlapped with the interval
      add(api.advance("tool", x, 1e-3, ForceMode::IntervalMean, [&] { ++works; }));
    }
    seen.push_back(api.time());
  }
  add(api.advance("tool", {}, 1e-3, ForceMode::Instantaneous, {}));  // a rigid tool: positions kept
  seen.push_back(works);
  add(api.nodePositions("tool"));
  return seen;
}

}  // namespace

TEST_CASE("the remote proxy is indistinguishable from the local backend (bit-identical results)", "[adapter]") {
  auto local = harmonic();
  const auto expected = exercise(*local);
  demfem::protocol::Context context;
  for (const std::string endpoint : {"inproc://proxy-test", "tcp://127.0.0.1:*"}) {
    ServedBackend served(context, endpoint);
    RemoteProxy proxy({served.socket.endpoint(), 5s, std::nullopt, "test"}, &context);
    CHECK(proxy.info().backend == "harmonic");
    CHECK(exercise(proxy) == expected);
    proxy.shutdown();
    proxy.shutdown();  // idempotent
    CHECK_THROWS_AS(proxy.time(), CouplingError);
  }
}

TEST_CASE("the remote proxy rethrows server errors with their codes", "[adapter]") {
  demfem::protocol::Context context;
  ServedBackend served(context, "inproc://proxy-errors");
  RemoteProxy proxy({served.socket.endpoint(), 5s, std::nullopt, "test"}, &context);
  try {
    proxy.nodeForces("plough");
    FAIL("unknown geometry accepted");
  } catch (const CouplingError& e) {
    CHECK(e.code() == ErrorCode::UnknownGeometry);
    CHECK_THAT(e.what(), Catch::Contains("plough"));
  }
  CHECK_THROWS_AS(proxy.setNodePositions("tool", {1, 2}), CouplingError);
  CHECK(proxy.time() == 0.0);  // still usable
  proxy.shutdown();
}

TEST_CASE("the remote proxy refuses a server of another protocol version", "[adapter]") {
  demfem::protocol::Context context;
  p::ServerSocket socket(context, "inproc://future-server");
  std::thread server([&] {
    auto request = socket.receive(5s);
    if (!request) return;
    const auto r = p::decodeRequest(request->message);
    socket.send(request->from, p::encode(p::Reply{r.seq, "hello", p::HelloReply{2, "future", "9", 1e-5}}));
  });
  try {
    RemoteProxy proxy({"inproc://future-server", 5s, std::nullopt, "test"}, &context);
    FAIL("version 2 server accepted");
  } catch (const CouplingError& e) {
    CHECK(e.code() == ErrorCode::VersionMismatch);
  }
  server.join();
}

TEST_CASE("the remote proxy times out with a clear message when no server answers", "[adapter]") {
  demfem::protocol::Context context;
  p::ServerSocket silent(context, "tcp://127.0.0.1:*", {.insecure_tcp = true});
  try {
    RemoteProxy proxy({silent.endpoint(), 300ms, std::nullopt, "test"}, &context);
    FAIL("connected to nobody");
  } catch (const CouplingError& e) {
    CHECK(e.code() == ErrorCode::Timeout);
    CHECK_THAT(e.what(), Catch::Contains("DEM server"));
  }
}

TEST_CASE("a served backend whose client vanished gives up after the idle timeout", "[adapter]") {
  demfem::protocol::Context context;
  auto api = harmonic();
  p::ServerSocket socket(context, "inproc://abandoned");
  Server server(*api, idle(100ms));
  CHECK_THROWS_WITH(server.serve(socket, 100ms), Catch::Contains("no request"));
  CHECK_THROWS_AS(api->time(), CouplingError);  // backend was shut down
}

TEST_CASE("a second client is told the server is busy, the first keeps its session, and a crashed client can come back",
          "[adapter]") {
  demfem::protocol::Context context;
  auto api = harmonic();
  p::ServerSocket socket(context, "tcp://127.0.0.1:*", {.insecure_tcp = true});
  Server server(*api, idle(300ms));
  std::thread thread([&] {
    try {
      server.serve(socket, 10s);
    } catch (const CouplingError&) {
    }
  });
  {
    RemoteProxy first({socket.endpoint(), 5s, std::nullopt, "first"}, &context);
    first.simulate(1e-3);
    try {
      RemoteProxy second({socket.endpoint(), 5s, std::nullopt, "second"}, &context);
      FAIL("a second client got a session");
    } catch (const CouplingError& e) {
      CHECK(e.code() == ErrorCode::Busy);
    }
    first.simulate(1e-3);  // undisturbed
    CHECK(first.time() == Approx(2e-3).epsilon(1e-12));
    // `first` now vanishes without shutting down, as a crashed client does.
  }
  std::this_thread::sleep_for(400ms);
  RemoteProxy again({socket.endpoint(), 5s, std::nullopt, "restarted"}, &context);
  CHECK(again.time() == Approx(2e-3).epsilon(1e-12));
  CHECK_THROWS_WITH(again.checkpoint("/tmp/x.ckpt"), Catch::Contains("named, not located"));
  again.shutdown();
  thread.join();
  CHECK(server.shutdownDone());
}
