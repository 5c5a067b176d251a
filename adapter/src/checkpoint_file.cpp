#include "demfem/adapter/checkpoint_file.hpp"

#include "demfem/adapter/output_files.hpp"

#include "demfem/study/study.hpp"

#include <cstring>
#include <fstream>

namespace demfem::adapter {

namespace {

constexpr char kMagic[8] = {'D', 'F', 'C', 'K', 'P', 'T', '\r', '\n'};

template <class T> void putAt(std::string& image, std::size_t offset, const T& value) {
  std::memcpy(image.data() + offset, &value, sizeof value);
}
template <class T> T getAt(const std::string& image, std::size_t offset) {
  T value;
  std::memcpy(&value, image.data() + offset, sizeof value);
  return value;
}

std::string kindField(const std::string& kind) {
  if (kind.empty() || kind.size() > kCheckpointKindBytes)
    throw CouplingError(ErrorCode::Internal, "checkpoint kind '" + kind + "' must have 1 to 16 characters");
  std::string field(kCheckpointKindBytes, '\0');
  field.replace(0, kind.size(), kind);
  return field;
}

[[noreturn]] void invalid(const std::string& what, const std::string& why) {
  throw CouplingError(ErrorCode::BadRequest, what + ": " + why);
}

}  // namespace

void PayloadReader::fail(const std::string& what) const {
  throw CouplingError(ErrorCode::BadRequest, what_ + ": inconsistent checkpoint content: " + what);
}

std::string checkpointImage(const std::string& kind, const std::string& payload) {
  std::string image(kCheckpointHeaderBytes, '\0');
  image.replace(0, sizeof kMagic, kMagic, sizeof kMagic);
  putAt(image, 8, kCheckpointFormatVersion);
  image.replace(16, kCheckpointKindBytes, kindField(kind));
  putAt(image, 32, static_cast<std::uint64_t>(payload.size()));
  putAt(image, 40, study::fnv1a64(payload));
  return image + payload;
}

std::string checkpointPayload(const std::string& image, const std::string& kind, const std::string& what) {
  if (image.size() < kCheckpointHeaderBytes)
    invalid(what, "shorter (" + std::to_string(image.size()) + " bytes) than a checkpoint header");
  if (image.compare(0, sizeof kMagic, kMagic, sizeof kMagic) != 0) invalid(what, "not a demfem checkpoint (bad magic)");
  if (const auto version = getAt<std::uint32_t>(image, 8); version != kCheckpointFormatVersion)
    invalid(what, "checkpoint format version " + std::to_string(version) + ", this program reads version " +
                      std::to_string(kCheckpointFormatVersion));
  if (getAt<std::uint32_t>(image, 12) != 0) invalid(what, "reserved header field is not zero");
  if (image.compare(16, kCheckpointKindBytes, kindField(kind)) != 0)
    invalid(what, "not a '" + kind + "' checkpoint (written by another backend)");
  const auto size = getAt<std::uint64_t>(image, 32);
  if (size != image.size() - kCheckpointHeaderBytes)
    invalid(what, "states a payload of " + std::to_string(size) + " bytes but holds " +
                      std::to_string(image.size() - kCheckpointHeaderBytes) + " (truncated or extended)");
  std::string payload = image.substr(kCheckpointHeaderBytes);
  if (study::fnv1a64(payload) != getAt<std::uint64_t>(image, 40)) invalid(what, "checksum mismatch (corrupted file)");
  return payload;
}

void writeCheckpointFile(const std::filesystem::path& file, const std::string& kind, const std::string& payload) {
  try {
    writeFileAtomically(file, checkpointImage(kind, payload));
  } catch (const OutputError& e) {
    throw CouplingError(ErrorCode::Internal, std::string("writing checkpoint failed: ") + e.what());
  }
}

std::string readCheckpointFile(const std::filesystem::path& file, const std::string& kind, const std::string& description) {
  const std::string what = description + " " + file.string();
  std::error_code error;
  const auto bytes = std::filesystem::file_size(file, error);
  if (error) invalid(what, "cannot be read");
  if (bytes > kCheckpointHeaderBytes + kMaxCheckpointPayloadBytes)
    invalid(what, std::to_string(bytes) + " bytes, above the checkpoint size limit");
  std::ifstream in(file, std::ios::binary);
  std::string image(static_cast<std::size_t>(bytes), '\0');
  in.read(image.data(), static_cast<std::streamsize>(image.size()));
  if (!in || in.peek() != std::char_traits<char>::eof()) invalid(what, "cannot be read completely");
  return checkpointPayload(image, kind, what);
}

}  // namespace demfem::adapter
