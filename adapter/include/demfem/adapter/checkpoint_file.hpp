// Checkpoint files of the DEM backends: one container format, validated completely before a
// backend looks at its content (docs/reliability.md).
//
// Layout (little-endian, 48-byte header, then the payload):
//   offset  0  magic "DFCKPT\r\n" (8 bytes; the CR LF catches text-mode transfers)
//   offset  8  format version, u32 = kCheckpointFormatVersion
//   offset 12  reserved, u32 = 0
//   offset 16  kind, 16 bytes, NUL-padded ASCII ("builtin", "test-harmonic", ...)
//   offset 32  payload size in bytes, u64 (<= kMaxCheckpointPayloadBytes)
//   offset 40  FNV-1a 64 of the payload (study::fnv1a64), u64
//   offset 48  payload; the file ends exactly after it
//
// Contract
// - writeCheckpointFile() writes FILE atomically (output_files.hpp: every write, sync and the
//   rename checked): a reader sees the old file or the complete new one. Throws
//   CouplingError(Internal) naming the file and the system's reason.
// - readCheckpointFile() returns the payload only if the magic, version, kind, size and checksum all
//   hold; otherwise it throws CouplingError(BadRequest) naming the file and the first check that
//   failed. It reads at most the header plus the stated size (bounded) and never changes anything.
// - PayloadReader reads a validated payload with bounds checks: every read past the end or a
//   vector length above the bytes left throws CouplingError(BadRequest); finish() throws if bytes
//   are left over. Backends parse into new objects and swap them in only after finish().
#pragma once

#include "demfem/adapter/coupling_api.hpp"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <type_traits>
#include <vector>

namespace demfem::adapter {

inline constexpr std::uint32_t kCheckpointFormatVersion = 1;
inline constexpr std::uint64_t kMaxCheckpointPayloadBytes = std::uint64_t{16} << 30;  // 16 GiB
inline constexpr std::size_t kCheckpointHeaderBytes = 48;
inline constexpr std::size_t kCheckpointKindBytes = 16;

// The whole file image (header + payload) for `kind` (at most 16 characters).
std::string checkpointImage(const std::string& kind, const std::string& payload);
// Validates an image as readCheckpointFile() does; `what` names it in messages.
std::string checkpointPayload(const std::string& image, const std::string& kind, const std::string& what);

void writeCheckpointFile(const std::filesystem::path& file, const std::string& kind, const std::string& payload);
// `description` names the file's role in messages ("checkpoint FILE: ...").
std::string readCheckpointFile(const std::filesystem::path& file, const std::string& kind, const std::string& description = "checkpoint");

// Appends trivially copyable values and vectors (u64 length, then the elements) to a byte string.
class PayloadWriter {
 public:
  template <class T> void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof value);
  }
  template <class T> void putVector(const std::vector<T>& values) {
    put(static_cast<std::uint64_t>(values.size()));
    if (!values.empty()) bytes_.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  }
  void putString(const std::string& text) {
    put(static_cast<std::uint64_t>(text.size()));
    bytes_ += text;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class PayloadReader {
 public:
  PayloadReader(const std::string& bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}

  template <class T> T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    T value;
    std::memcpy(&value, take(sizeof(T)), sizeof(T));
    return value;
  }
  template <class T> void get(T& value) { value = get<T>(); }
  template <class T> std::vector<T> getVector() {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto n = get<std::uint64_t>();
    if (n > (bytes_.size() - offset_) / sizeof(T)) fail("array of " + std::to_string(n) + " elements runs past the end");
    std::vector<T> values(static_cast<std::size_t>(n));
    if (n) std::memcpy(values.data(), take(values.size() * sizeof(T)), values.size() * sizeof(T));
    return values;
  }
  template <class T> void getVector(std::vector<T>& values) { values = getVector<T>(); }
  std::string getString() {
    const auto chars = getVector<char>();
    return std::string(chars.begin(), chars.end());
  }
  void finish() const {
    if (offset_ != bytes_.size()) fail(std::to_string(bytes_.size() - offset_) + " bytes left over at the end");
  }
  [[noreturn]] void fail(const std::string& what) const;

 private:
  const char* take(std::size_t n) {
    if (n > bytes_.size() - offset_) fail("ends early (truncated payload)");
    const char* p = bytes_.data() + offset_;
    offset_ += n;
    return p;
  }

  const std::string& bytes_;
  std::string what_;
  std::size_t offset_ = 0;
};

}  // namespace demfem::adapter
