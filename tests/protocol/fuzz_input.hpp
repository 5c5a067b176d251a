// Fuzz inputs for the protocol: random and mutated multipart messages, and a byte-string -> frames
// split for libFuzzer. Deterministic for a given seed.
#pragma once

#include "demfem/protocol/codec.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <random>

namespace demfem::protocol::fuzz {

// libFuzzer input -> frames: each frame is a 2-byte little-endian length and that many bytes (the
// last frame takes what is left if the length runs past the end).
inline Multipart framesFromBytes(const std::uint8_t* data, std::size_t size) {
  Multipart frames;
  std::size_t pos = 0;
  while (pos + 2 <= size && frames.size() < kMaxFrames + 2) {
    const std::size_t length = data[pos] | (static_cast<std::size_t>(data[pos + 1]) << 8);
    pos += 2;
    const std::size_t take = std::min(length, size - pos);
    frames.emplace_back(reinterpret_cast<const char*>(data + pos), take);
    pos += take;
  }
  return frames;
}

class Mutator {
 public:
  explicit Mutator(std::uint64_t seed) : rng_(seed) {}

  // Random frames of random bytes, sometimes starting like a JSON header.
  Multipart random() {
    Multipart m(1 + below(4));
    for (auto& f : m) {
      f.resize(below(64));
      for (auto& c : f) c = static_cast<char>(below(256));
    }
    if (below(2)) m[0] = R"({"v":1,"op":")" + m[0];
    return m;
  }

  // One structural or byte-level mutation of a valid message.
  Multipart mutate(Multipart m) {
    switch (below(8)) {
      case 0:  // flip bytes anywhere
        for (int i = 0, n = 1 + below(4); i < n; ++i) {
          auto& f = m[below(m.size())];
          if (!f.empty()) f[below(f.size())] ^= static_cast<char>(1 + below(255));
        }
        break;
      case 1: {  // truncate a frame
        auto& f = m[below(m.size())];
        f.resize(below(f.size() + 1));
        break;
      }
      case 2:  // drop or duplicate a frame
        if (below(2) && m.size() > 1) m.erase(m.begin() + static_cast<long>(1 + below(m.size() - 1)));
        else m.push_back(m[below(m.size())]);
        break;
      case 3:
      case 4:
      case 5: {  // replace or delete a header field with a value of a random type
        nlohmann::json h = nlohmann::json::parse(m[0], nullptr, false);
        if (h.is_discarded() || !h.is_object() || h.empty()) break;
        auto it = h.begin();
        std::advance(it, static_cast<long>(below(h.size())));
        if (below(5) == 0) h.erase(it);
        else *it = randomValue();
        m[0] = h.dump();
        break;
      }
      case 6:  // garbage appended to the header
        m[0] += static_cast<char>(below(256));
        break;
      default:  // an array frame of random length
        if (m.size() > 1) m.back().resize(below(3 * m.back().size() + 9), static_cast<char>(below(256)));
        break;
    }
    return m;
  }

 private:
  std::size_t below(std::size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng_); }

  nlohmann::json randomValue() {
    switch (below(9)) {
      case 0: return nullptr;
      case 1: return -static_cast<std::int64_t>(below(1000)) - 1;
      case 2: return std::numeric_limits<std::uint64_t>::max() - below(10);
      case 3: return 1e308 * static_cast<double>(below(3));
      case 4: return "tool";
      case 5: return nlohmann::json::array({1, 2, 3});
      case 6: return nlohmann::json::object({{"code", 1}});
      case 7: return below(2) == 1;
      default: return below(4);
    }
  }

  std::mt19937_64 rng_;
};

}  // namespace demfem::protocol::fuzz
