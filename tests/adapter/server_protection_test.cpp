// A tcp DEM server against local peers that are not its client (docs/protocol.md "Sessions",
// docs/reliability.md "The server owns its session"): squatters without the client key, oversized
// requests from connections without the session, and hundreds of idle connections. Loopback only;
// every wait is bounded.
#include "demfem/adapter/remote_proxy.hpp"
#include "demfem/adapter/server.hpp"
#include "demfem/adapter/test_backends.hpp"

#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <thread>

using namespace demfem::adapter;
using namespace std::chrono_literals;
namespace p = demfem::protocol;
namespace fs = std::filesystem;

#if defined(__SANITIZE_ADDRESS__)
#define DEMFEM_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define DEMFEM_TEST_ASAN 1
#endif
#endif

namespace {

#ifdef DEMFEM_TEST_ASAN
constexpr bool kAddressSanitizer = true;  // its quarantine keeps freed blocks resident (256 MiB)
#else
constexpr bool kAddressSanitizer = false;
#endif

std::unique_ptr<CouplingApi> harmonic() { return makeTestBackend("harmonic", {demfem::study::Tool{}}, TestLoad{}); }

ServerOptions idle(std::chrono::milliseconds timeout) {
  ServerOptions options;
  options.idle_timeout = timeout;
  return options;
}

// A CurveZMQ-protected server on its own thread until shutdown or 10 s idle.
struct KeyedServer {
  KeyedServer(p::Context& context, const fs::path& keys)
      : api(harmonic()), socket(context, "tcp://127.0.0.1:*", {.security = p::loadServerSecurity(keys)}),
        server(*api, idle(10s)) {
    thread = std::thread([this] {
      try {
        server.serve(socket, 10s);
      } catch (const CouplingError&) {
      }
    });
  }
  ~KeyedServer() { thread.join(); }
  std::unique_ptr<CouplingApi> api;
  p::ServerSocket socket;
  Server server;
  std::thread thread;
};

// Resident set of this process (VmRSS of /proc/self/status), bytes.
std::size_t residentBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stoul(line.substr(6)) * 1024;
  FAIL("no VmRSS in /proc/self/status");
  return 0;
}

// User + system CPU time of process `pid` (/proc/PID/stat fields 14 and 15), seconds.
double cpuSeconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::istringstream fields(text.substr(text.rfind(')') + 2));  // after the command name
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> field; ++i)
    if (i >= 14) ticks += std::stod(field);
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

int tcpPort(const std::string& endpoint) { return std::stoi(endpoint.substr(endpoint.rfind(':') + 1)); }

// Opens up to `count` plain TCP connections to 127.0.0.1:port that never speak; returns their sockets.
std::vector<int> idleConnections(int port, int count) {
  std::vector<int> sockets;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  for (int i = 0; i < count; ++i) {
    const int s = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (s < 0) break;
    (void)::connect(s, reinterpret_cast<const sockaddr*>(&address), sizeof address);  // EINPROGRESS is fine
    sockets.push_back(s);
  }
  return sockets;
}

}  // namespace

TEST_CASE("a squatter without the client key cannot take a tcp server's session, and the real client then gets it",
          "[adapter]") {
  demfem::support::TempDir keys("squat-keys"), other("squat-other");
  p::writeCurveKeyDirectory(keys.path());
  p::writeCurveKeyDirectory(other.path());
  p::Context context;
  KeyedServer served(context, keys.path());
  const std::string endpoint = served.socket.endpoint();

  // No CurveZMQ at all, then the server's public key with a key pair the server does not list.
  p::ClientSecurity foreign = p::loadClientSecurity(keys.path());
  foreign.client = p::loadClientSecurity(other.path()).client;
  for (const auto& security : {std::optional<p::ClientSecurity>(), std::optional(foreign)}) {
    try {
      RemoteProxy squatter({endpoint, 1s, security, "squatter"}, &context);
      FAIL("a squatter got a session");
    } catch (const CouplingError& e) {
      CHECK((e.code() == ErrorCode::PeerGone || e.code() == ErrorCode::Timeout));
    }
  }
  const auto start = std::chrono::steady_clock::now();
  RemoteProxy client({endpoint, 5s, p::loadClientSecurity(keys.path()), "client"}, &context);
  client.simulate(1e-3);
  CHECK(client.time() == Approx(1e-3).margin(1e-12));
  // The session was free: no waiting for a squatter's idle timeout (10 s here).
  CHECK(std::chrono::steady_clock::now() - start < 2s);
  client.shutdown();
}

TEST_CASE("a 48 MiB request from a connection without the session is dropped unread and the memory comes back",
          "[adapter]") {
  demfem::support::TempDir keys("large-keys");
  p::writeCurveKeyDirectory(keys.path());
  p::Context context;
  KeyedServer served(context, keys.path());
  RemoteProxy owner({served.socket.endpoint(), 5s, p::loadClientSecurity(keys.path()), "owner"}, &context);
  owner.simulate(1e-3);

  // An authenticated peer without the session: a valid header, then a 48 MiB frame (above glibc's
  // largest mmap threshold, 32 MiB, so a freed buffer goes back to the system at once).
  const std::string header = R"({"v":1,"op":"set_node_positions","seq":7,"geometry":"tool","n":2097152})";
  const std::string payload(48u << 20, '\x01');
  p::ClientSocket intruder(context, served.socket.endpoint(), 10s, p::loadClientSecurity(keys.path()));
  const std::size_t before = residentBytes();
  for (int round = 0; round < 4; ++round) {
    const p::Reply reply = p::decodeReply(intruder.request({header, payload}));
    const auto* error = std::get_if<p::ErrorReply>(&reply.body);
    REQUIRE(error != nullptr);
    CHECK(error->code == p::WireError::BadRequest);
    CHECK_THAT(error->message, Catch::Contains("dropped unread"));
    owner.simulate(1e-3);  // the owner is served between the floods
  }
  const std::size_t after = residentBytes();
  // 4 x 48 MiB went through; what stays is bounded by 8 MiB (allocator noise).
  if (!kAddressSanitizer) CHECK(after < before + (8u << 20));
  CHECK(owner.time() == Approx(5e-3).margin(1e-12));
  owner.shutdown();
}

// The server runs in a child process with its own file-descriptor limit, so its CPU time can be
// read alone. Two ways to the limit: more connections than max_connections (64, fds to spare), and
// fewer descriptors (48) than the connections allowed (1000), where accepting fails.
TEST_CASE("300 idle connections neither stop the owner's requests nor make a tcp server spin", "[adapter]") {
  struct Limits {
    rlim_t descriptors;
    std::size_t max_connections;
  };
  for (const Limits limits : {Limits{1024, 64}, Limits{48, 1000}}) {
    CAPTURE(limits.descriptors, limits.max_connections);
    demfem::support::TempDir keys("flood-keys");
    p::writeCurveKeyDirectory(keys.path());
    int endpoint_pipe[2];
    REQUIRE(::pipe2(endpoint_pipe, O_CLOEXEC) == 0);
    const pid_t child = ::fork();
    REQUIRE(child >= 0);
    if (child == 0) {  // the server: no Catch2 here, only _exit
      ::close(endpoint_pipe[0]);
      rlimit descriptors{limits.descriptors, limits.descriptors};
      int status = ::setrlimit(RLIMIT_NOFILE, &descriptors) == 0 ? 0 : 2;
      try {
        p::Context context;
        auto api = harmonic();
        p::ServerSocket socket(context, "tcp://127.0.0.1:*",
                               {.security = p::loadServerSecurity(keys.path()), .max_connections = limits.max_connections});
        const std::string endpoint = socket.endpoint() + "\n";
        if (::write(endpoint_pipe[1], endpoint.data(), endpoint.size()) != static_cast<ssize_t>(endpoint.size())) status = 3;
        ::close(endpoint_pipe[1]);
        Server server(*api, idle(10s));
        server.serve(socket, 10s);
      } catch (...) {
        status = 4;
      }
      ::_exit(status);
    }
    ::close(endpoint_pipe[1]);
    pollfd ready{endpoint_pipe[0], POLLIN, 0};
    REQUIRE(::poll(&ready, 1, 10000) == 1);
    char text[128] = {};
    REQUIRE(::read(endpoint_pipe[0], text, sizeof text - 1) > 0);
    ::close(endpoint_pipe[0]);
    const std::string endpoint = std::string(text).substr(0, std::string(text).find('\n'));

    p::Context context;
    RemoteProxy owner({endpoint, 5s, p::loadClientSecurity(keys.path()), "owner"}, &context);
    owner.simulate(1e-3);
    std::vector<int> flood = idleConnections(tcpPort(endpoint), 300);
    CHECK(flood.size() == 300);
    std::this_thread::sleep_for(500ms);  // the server accepts them (or fails to)
    for (int i = 0; i < 5; ++i) owner.simulate(1e-3);  // 5 s timeout each
    CHECK(owner.time() == Approx(6e-3).margin(1e-12));
    // An idle second with the 300 connections still open on this side: a spinning server would use
    // about 1 s of CPU here; an idle one a few milliseconds (monitor and ZAP threads poll at 50-100 ms).
    const double cpu_before = cpuSeconds(child);
    std::this_thread::sleep_for(1s);
    const double idle_cpu = cpuSeconds(child) - cpu_before;
    CHECK(idle_cpu < 0.1);
    // A new client is still accepted and answered (Busy: the owner holds the session), not ignored.
    try {
      RemoteProxy late({endpoint, 3s, p::loadClientSecurity(keys.path()), "late"}, &context);
      FAIL("a second client got the session");
    } catch (const CouplingError& e) {
      CHECK(e.code() == ErrorCode::Busy);
    }
    owner.simulate(1e-3);
    owner.shutdown();
    for (const int s : flood) ::close(s);
    int status = -1;
    for (int i = 0; i < 100 && ::waitpid(child, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(100ms);
    if (status == -1) {
      ::kill(child, SIGKILL);
      ::waitpid(child, &status, 0);
    }
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 0);
  }
}
