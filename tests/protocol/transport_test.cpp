#include "demfem/protocol/transport.hpp"

#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <thread>

using namespace demfem::protocol;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

// Echo server on its own thread: answers `count` requests with the request itself.
std::thread echo(ServerSocket& server, int count, std::chrono::milliseconds wait = 5s) {
  return std::thread([&server, count, wait] {
    for (int i = 0; i < count; ++i) {
      auto request = server.receive(wait);
      if (!request) return;
      server.send(request->from, request->message);
    }
  });
}


}  // namespace

TEST_CASE("multipart messages cross inproc, ipc and tcp unchanged", "[protocol]") {
  const fs::path dir = demfem::support::freshDir("ipc");
  for (const std::string& endpoint : {std::string("inproc://transport-test"), "ipc://" + (dir / "s").string(),
                                     std::string("tcp://127.0.0.1:*")}) {
    demfem::protocol::Context context;
    ServerSocket server(context, endpoint, {.insecure_tcp = true});
    auto thread = echo(server, 1);
    ClientSocket client(context, server.endpoint(), 5s);
    const Multipart message{R"({"v":1})", std::string("\0\1\2\3", 4), ""};
    CHECK(client.request(message) == message);
    thread.join();
  }
  fs::remove_all(dir);
}

// The server answers only after the client's work has run, so the work cannot have waited for the
// reply; a throwing work is rethrown after the reply, and the socket serves the next request.
TEST_CASE("a request's meanwhile work runs before its reply is awaited, and its exception leaves the socket in step",
          "[protocol]") {
  demfem::protocol::Context context;
  ServerSocket server(context, "inproc://meanwhile-test");
  std::atomic<bool> work_done{false};
  std::atomic<int> answered_after_work{0};
  std::thread thread([&] {
    for (int i = 0; i < 3; ++i) {
      auto request = server.receive(5s);
      if (!request) return;
      const auto give_up = std::chrono::steady_clock::now() + 5s;
      while (!work_done.load() && std::chrono::steady_clock::now() < give_up) std::this_thread::sleep_for(1ms);
      if (work_done.load()) ++answered_after_work;
      server.send(request->from, request->message);
    }
  });
  ClientSocket client(context, server.endpoint(), 10s);
  const Multipart first{"first"};
  CHECK(client.request(first, [&] { work_done = true; }) == first);
  work_done = false;
  CHECK_THROWS_WITH(client.request({"second"},
                                   [&] {
                                     work_done = true;
                                     throw std::runtime_error("disk full");
                                   }),
                    "disk full");
  work_done = true;
  const Multipart third{"third"};
  CHECK(client.request(third) == third);  // the second reply was consumed: the third gets its own
  thread.join();
  CHECK(answered_after_work.load() == 3);
}

TEST_CASE("a client whose server never answers times out with a message saying the peer is gone", "[protocol]") {
  demfem::protocol::Context context;
  ServerSocket silent(context, "tcp://127.0.0.1:*", {.insecure_tcp = true});
  ClientSocket client(context, silent.endpoint(), 300ms);
  const auto start = std::chrono::steady_clock::now();
  try {
    client.request({"{}"});
    FAIL("no timeout");
  } catch (const ProtocolError& e) {
    CHECK(e.code() == WireError::Timeout);
    CHECK_THAT(e.what(), Catch::Contains("peer is gone"));
  }
  CHECK(std::chrono::steady_clock::now() - start < 3s);
  // The REQ socket is now unusable; it says so instead of hanging.
  CHECK_THROWS_AS(client.request({"{}"}), ProtocolError);
}

TEST_CASE("a server that goes away while a request is pending fails it at once, not after the timeout", "[protocol]") {
  demfem::protocol::Context context;
  auto server = std::make_unique<ServerSocket>(context, "tcp://127.0.0.1:*", ServerSocketOptions{.insecure_tcp = true});
  ClientSocket client(context, server->endpoint(), 20s);
  std::thread closer([&] {
    if (server->receive(5s)) server.reset();  // takes the request, never answers, closes
  });
  const auto start = std::chrono::steady_clock::now();
  try {
    client.request({"{}"});
    FAIL("a reply from a closed server");
  } catch (const ProtocolError& e) {
    CHECK(e.code() == WireError::PeerGone);
    CHECK_THAT(e.what(), Catch::Contains("closed the connection"));
  }
  CHECK(std::chrono::steady_clock::now() - start < 5s);
  closer.join();
}

TEST_CASE("a server receive returns nothing after its timeout", "[protocol]") {
  demfem::protocol::Context context;
  ServerSocket server(context, "inproc://idle");
  CHECK_FALSE(server.receive(50ms).has_value());
}

TEST_CASE("binding ipc never deletes a file that is not a socket", "[protocol]") {
  const fs::path dir = demfem::support::freshDir("ipc-file");
  const fs::path precious = dir / "precious.txt";
  { std::ofstream(precious) << "keep me\n"; }
  demfem::protocol::Context context;
  CHECK_THROWS_WITH(ServerSocket(context, "ipc://" + precious.string()), Catch::Contains("not a socket"));
  CHECK(fs::file_size(precious) == 8);
  {  // a socket left by an earlier server may be replaced
    ServerSocket first(context, "ipc://" + (dir / "dem.ipc").string());
  }
  CHECK(fs::is_socket(dir / "dem.ipc"));
  CHECK_NOTHROW(ServerSocket(context, "ipc://" + (dir / "dem.ipc").string()));
  fs::remove_all(dir);
}

TEST_CASE("an ipc socket file is created with mode 0600, whatever the umask", "[protocol]") {
  const fs::path dir = demfem::support::freshDir("ipc-mode");
  const mode_t umask_before = ::umask(0);  // the loosest umask: the socket would be 0777
  {
    demfem::protocol::Context context;
    ServerSocket server(context, "ipc://" + (dir / "dem.ipc").string());
    CHECK(fs::status(dir / "dem.ipc").permissions() == (fs::perms::owner_read | fs::perms::owner_write));
  }
  CHECK(::umask(umask_before) == 0);  // the process's umask is given back
  fs::remove_all(dir);
}

TEST_CASE("a message larger than a hello from a connection without the session comes back dropped, the owner's whole",
          "[protocol]") {
  demfem::protocol::Context context;
  ServerSocket server(context, "inproc://sizes");
  ClientSocket a(context, "inproc://sizes", 5s), b(context, "inproc://sizes", 5s);
  const std::string big(kMaxUnownedRequestBytes + 1, 'x'), hello(kMaxUnownedRequestBytes, 'h');
  std::vector<Incoming> seen;
  std::thread thread([&] {
    for (int i = 0; i < 5; ++i) {
      auto in = server.receive(5s);
      if (!in) return;
      if (i == 1) server.setOwner(in->from);  // a's second request: a owns the session from here
      seen.push_back(*in);
      server.send(in->from, {"ok"});
    }
  });
  a.request({hello});                                    // 0: a hello-sized message is read
  a.request({big});                                      // 1: too large, a owns nothing yet
  a.request({"{}", big});                                // 2: a is the owner: read whole
  b.request({big});                                      // 3: b is not
  b.request(Multipart(kMaxFrames + 1, std::string()));  // 4: too many frames, b is not the owner
  thread.join();
  REQUIRE(seen.size() == 5);
  CHECK(seen[0].message == Multipart{hello});
  CHECK_FALSE(seen[0].dropped);
  CHECK(seen[1].dropped);
  CHECK(seen[1].message.empty());
  CHECK(seen[1].bytes == kMaxUnownedRequestBytes + 1);
  CHECK_FALSE(seen[2].dropped);
  CHECK(seen[2].message == Multipart{"{}", big});
  CHECK(seen[3].dropped);
  CHECK(seen[3].message.empty());
  CHECK(seen[4].dropped);  // no bytes, but more frames than any request has
  CHECK(seen[4].message.empty());
}

TEST_CASE("past max_connections every tcp connection but the owner's is closed, and that is logged once",
          "[protocol]") {
  demfem::protocol::Context context;
  std::atomic<int> logged{0};
  ServerSocket server(context, "tcp://127.0.0.1:*",
                      {.insecure_tcp = true, .max_connections = 4, .log = [&](const std::string&) { ++logged; }});
  ClientSocket owner(context, server.endpoint(), 5s);
  std::thread thread([&] {
    for (int i = 0; i < 2; ++i) {
      auto in = server.receive(5s);
      if (!in) return;
      server.setOwner(in->from);
      server.send(in->from, in->message);
    }
  });
  REQUIRE(owner.request({"first"}) == Multipart{"first"});
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(std::stoi(server.endpoint().substr(server.endpoint().rfind(':') + 1))));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  for (int flood = 0; flood < 2; ++flood) {
    std::vector<int> sockets;
    for (int i = 0; i < 10; ++i) {
      sockets.push_back(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
      REQUIRE(::connect(sockets.back(), reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0);
    }
    // The server closes them: past ZeroMQ's greeting each reads end-of-file (or a reset) within 2 s;
    // up to 4 may have come in just after a shedding and be kept (until their handshake times out).
    int closed = 0;
    std::vector<pollfd> open;
    for (const int s : sockets) open.push_back({s, POLLIN, 0});
    const auto deadline = std::chrono::steady_clock::now() + 2s;
    while (closed < 10 - 4) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0 || ::poll(open.data(), open.size(), static_cast<int>(left.count())) <= 0) break;
      for (pollfd& p : open) {
        char bytes[256];
        if (p.fd < 0 || !(p.revents & (POLLIN | POLLHUP | POLLERR))) continue;
        if (::recv(p.fd, bytes, sizeof bytes, 0) <= 0) {
          ++closed;
          p.fd = -1;  // poll ignores it from now on
        }
      }
    }
    for (const int s : sockets) ::close(s);
    CHECK(closed >= 10 - 4);
  }
  CHECK(server.connectionSheddings() >= 2);
  CHECK(logged.load() == 1);
  CHECK(owner.request({"second"}) == Multipart{"second"});  // the owner's connection was never closed
  thread.join();
}

TEST_CASE("each reply goes back to the connection its request came on", "[protocol]") {
  demfem::protocol::Context context;
  ServerSocket server(context, "inproc://routing");
  ClientSocket a(context, "inproc://routing", 5s), b(context, "inproc://routing", 5s);
  std::thread thread([&] {
    std::vector<Incoming> in;
    for (int i = 0; i < 2; ++i)
      if (auto r = server.receive(5s)) in.push_back(*r);
    if (in.size() != 2) return;
    CHECK(in[0].from.routing_id != in[1].from.routing_id);
    for (auto it = in.rbegin(); it != in.rend(); ++it) server.send(it->from, {"to " + it->message[0]});
  });
  std::thread other([&] { CHECK(b.request({"b"}) == Multipart{"to b"}); });
  CHECK(a.request({"a"}) == Multipart{"to a"});
  other.join();
  thread.join();
}

TEST_CASE("binding tcp needs CurveZMQ keys, or an explicit insecure flag on a loopback address only", "[protocol]") {
  CHECK_THROWS_WITH(checkBindEndpoint("tcp://127.0.0.1:5555", false), Catch::Contains("any local process"));
  CHECK_THROWS_WITH(checkBindEndpoint("tcp://localhost:*", false), Catch::Contains("--curve-keys"));
  CHECK_NOTHROW(checkBindEndpoint("tcp://127.0.0.1:5555", false, true));
  CHECK_NOTHROW(checkBindEndpoint("tcp://localhost:*", false, true));
  CHECK_NOTHROW(checkBindEndpoint("tcp://127.0.0.1:5555", true));
  CHECK_NOTHROW(checkBindEndpoint("ipc:///run/demfem.sock", false));
  CHECK_THROWS_WITH(checkBindEndpoint("tcp://*:5555", false), Catch::Contains("--curve-keys"));
  CHECK_THROWS_WITH(checkBindEndpoint("tcp://0.0.0.0:5555", false, true), Catch::Contains("non-loopback"));
  CHECK_NOTHROW(checkBindEndpoint("tcp://*:5555", true));
  demfem::protocol::Context context;
  CHECK_THROWS_WITH(ServerSocket(context, "tcp://127.0.0.1:*"), Catch::Contains("without authentication"));
  CHECK_THROWS_AS(checkBindEndpoint("udp://127.0.0.1:1", false), std::invalid_argument);
}

TEST_CASE("CurveZMQ: the keyed client is served, a client with another key is refused", "[protocol]") {
  const fs::path keys = demfem::support::freshDir("keys"), other = demfem::support::freshDir("other-keys");
  writeCurveKeyDirectory(keys);
  writeCurveKeyDirectory(other);
  CHECK((fs::status(keys / "client.secret").permissions() & fs::perms::others_read) == fs::perms::none);
  demfem::protocol::Context context;
  ServerSocket server(context, "tcp://127.0.0.1:*", {.security = loadServerSecurity(keys)});
  auto thread = echo(server, 1);
  {
    ClientSocket good(context, server.endpoint(), 5s, loadClientSecurity(keys));
    CHECK(good.request({"hi"}) == Multipart{"hi"});
  }
  thread.join();

  // Knows the server's public key but holds a key pair the server does not accept.
  ClientSecurity intruder = loadClientSecurity(keys);
  intruder.client = loadClientSecurity(other).client;
  auto listener = echo(server, 1, 1s);
  ClientSocket bad(context, server.endpoint(), 3s, intruder);
  try {
    bad.request({"let me in"});
    FAIL("a client with the wrong key was served");
  } catch (const ProtocolError& e) {
    CHECK(e.code() == WireError::PeerGone);
    CHECK_THAT(e.what(), Catch::Contains("CurveZMQ"));
  }
  listener.join();  // the server saw no request (receive timed out)
  fs::remove_all(keys);
  fs::remove_all(other);
}

TEST_CASE("a missing or malformed key file, or a secret one others may read, is named in the error", "[protocol]") {
  const fs::path dir = demfem::support::freshDir("badkeys");
  CHECK_THROWS_WITH(loadServerSecurity(dir), Catch::Contains("server.pub"));
  writeCurveKeyDirectory(dir);
  { std::ofstream(dir / "client.pub") << "short\n"; }
  CHECK_THROWS_WITH(loadServerSecurity(dir), Catch::Contains("40-character"));
  writeCurveKeyDirectory(dir);
  fs::permissions(dir / "server.secret", fs::perms::group_read, fs::perm_options::add);
  CHECK_THROWS_WITH(loadServerSecurity(dir), Catch::Contains("server.secret") && Catch::Contains("other users"));
  fs::remove_all(dir);
}
