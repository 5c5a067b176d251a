// Fuzz test run in CI: >= 1e5 random and mutated messages through the decoders. Every input must be
// either decoded or rejected with ProtocolError; anything else (crash, other exception) fails.
// The libFuzzer target fuzz_codec_libfuzzer.cpp does the same for longer runs.
#include "demfem/protocol/codec.hpp"
#include "fuzz_input.hpp"
#include "sample_messages.hpp"

#include <catch2/catch.hpp>

using namespace demfem::protocol;

namespace {

struct Outcome {
  std::size_t accepted = 0, rejected = 0;
};

template <class Decode>
void feed(const Multipart& m, Decode decode, Outcome& outcome) {
  try {
    decode(m);
    ++outcome.accepted;
  } catch (const ProtocolError&) {
    ++outcome.rejected;
  }
}

}  // namespace

TEST_CASE("codec fuzz: 1e5 random and mutated requests are decoded or rejected, never crash", "[protocol]") {
  fuzz::Mutator mutator(20261122);
  std::vector<Multipart> seeds;
  for (const auto& r : samples::requests()) seeds.push_back(encode(r));
  Outcome outcome;
  const auto decode = [](const Multipart& m) { decodeRequest(m); };
  for (int i = 0; i < 100000; ++i) {
    if (i % 4 == 0) feed(mutator.random(), decode, outcome);
    else {
      Multipart m = seeds[static_cast<std::size_t>(i) % seeds.size()];
      for (int k = 0; k <= i % 3; ++k) m = mutator.mutate(std::move(m));
      feed(m, decode, outcome);
    }
  }
  CHECK(outcome.accepted + outcome.rejected == 100000);
  // The mutations must exercise both paths, or the test proves nothing.
  CHECK(outcome.rejected > 50000);
  CHECK(outcome.accepted > 1000);
}

TEST_CASE("codec fuzz: 1e5 random and mutated replies are decoded or rejected, never crash", "[protocol]") {
  fuzz::Mutator mutator(7);
  std::vector<Multipart> seeds;
  for (const auto& r : samples::replies()) seeds.push_back(encode(r));
  Outcome outcome;
  const auto decode = [](const Multipart& m) { decodeReply(m); };
  for (int i = 0; i < 100000; ++i) {
    if (i % 4 == 0) feed(mutator.random(), decode, outcome);
    else feed(mutator.mutate(seeds[static_cast<std::size_t>(i) % seeds.size()]), decode, outcome);
  }
  CHECK(outcome.rejected > 50000);
  CHECK(outcome.accepted > 1000);
}
