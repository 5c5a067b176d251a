// libFuzzer target for the server's dispatch and session logic (adapter/server.hpp): a fresh
// server over the harmonic test backend, with a checkpoint directory, gets a sequence of requests
// from two connections. Every reply must decode; anything else (crash, sanitizer report, an
// exception out of handle(), an undecodable reply) aborts and libFuzzer keeps the input.
//
// Input: records of [flags u8][length u16 LE][length bytes]. The bytes become frames by
// fuzz::framesFromBytes(). flags bit 0: sent by the second connection; bit 1: the current session
// token is put into the header (so the fuzzer reaches the calls behind the session check); bit 2:
// the clock advances past the idle timeout before the request.
#include "demfem/adapter/server.hpp"
#include "demfem/adapter/test_backends.hpp"
#include "../protocol/fuzz_input.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <unistd.h>

namespace {

namespace p = demfem::protocol;
namespace fs = std::filesystem;

const fs::path& checkpointDir() {
  static const fs::path dir = fs::temp_directory_path() / ("demfem-fuzz-server-" + std::to_string(getpid()));
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace demfem::adapter;
  fs::remove_all(checkpointDir());
  fs::create_directories(checkpointDir());
  auto api = makeTestBackend("harmonic", {demfem::study::Tool{}}, TestLoad{});
  ServerOptions options;
  options.checkpoint_dir = checkpointDir();
  options.idle_timeout = std::chrono::seconds(1);
  Server server(*api, options);
  const p::PeerAddress peers[2] = {{"owner", true}, {"other", true}};
  auto now = Server::Clock::time_point{};
  std::string token;
  const auto send = [&](const p::PeerAddress& from, const p::Multipart& message) {
    const p::Reply reply = p::decodeReply(server.handle(from, message, now));  // must decode
    if (const auto* hello = std::get_if<p::HelloReply>(&reply.body)) token = hello->session;
  };
  send(peers[0], p::encode(p::Request{1, p::Hello{1, "fuzz"}}));
  std::size_t pos = 0;
  while (pos + 3 <= size) {
    const std::uint8_t flags = data[pos];
    const std::size_t length = std::min<std::size_t>(data[pos + 1] | (data[pos + 2] << 8), size - pos - 3);
    p::Multipart message = p::fuzz::framesFromBytes(data + pos + 3, length);
    pos += 3 + length;
    if ((flags & 2) && !message.empty()) {
      nlohmann::json header = nlohmann::json::parse(message[0], nullptr, false);
      if (header.is_object()) {
        header["session"] = token;
        message[0] = header.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      }
    }
    if (flags & 4) now += std::chrono::milliseconds(1500);
    send(peers[flags & 1], message);
  }
  return 0;
}
