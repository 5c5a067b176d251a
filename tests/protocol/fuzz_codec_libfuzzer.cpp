// libFuzzer target for the protocol decoders (longer runs than the CI fuzz test):
//   cmake -DCMAKE_CXX_COMPILER=clang++ ... && cmake --build . --target protocol_fuzz_codec
//   ./tests/protocol/protocol_fuzz_codec -max_total_time=600
// Input bytes are split into frames by fuzz::framesFromBytes(). Only ProtocolError may escape the
// decoders; anything else aborts and libFuzzer reports the input.
#include "demfem/protocol/codec.hpp"
#include "fuzz_input.hpp"

#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace demfem::protocol;
  const Multipart frames = fuzz::framesFromBytes(data, size);
  try {
    decodeRequest(frames);
  } catch (const ProtocolError&) {
  }
  try {
    decodeReply(frames);
  } catch (const ProtocolError&) {
  }
  return 0;
}
