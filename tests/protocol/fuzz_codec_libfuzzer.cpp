// libFuzzer target for the protocol decoders, built by the sanitizer build (scripts/test.sh,
// docs/reliability.md) and run there as the ctest test fuzz:protocol_fuzz_codec; longer runs:
//   build-sanitize/tests/protocol/protocol_fuzz_codec -max_total_time=600 CORPUS_DIR
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
