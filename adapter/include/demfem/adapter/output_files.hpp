// Checked output files: every write, flush, sync, close and rename is checked, and a failure
// throws OutputError naming the file and the system's reason (e.g. "No space left on device").
// Shared by the FEM client's outputs (fem/coupled_driver.hpp), the DEM backends' checkpoints and
// VTK files, and the VTK time-series collections (.pvd) both write.
//
// Contract
// - writeFileAtomically(): the one checked atomic write of a whole file (binary formats, JSON
//   reports, caches): the content goes to FILE.<pid>-<thread>.partial, which is closed (and with
//   Durability::Synced first synced) and then renamed over FILE; on any failure FILE is unchanged
//   (the old content or absent) and the temporary is removed. Writers of one file in several
//   processes or threads never share a temporary; the last rename wins. Either durability leaves
//   FILE whole or unchanged when the process ends however it ends; only Synced also survives the
//   machine's end (a power loss), at the cost of waiting for the device (about 0.5 ms a file
//   here): checkpoints, caches and run records are Synced, visualisation files Unsynced.
// - CheckedFile: an output written in pieces; write() passes every byte to the system (no hidden
//   buffer), so a full disk is reported by the write that hits it. close() syncs before closing.
// - VtkSeries: a ParaView collection (.pvd, XML) listing data files with their simulated time;
//   rewritten atomically (Unsynced, as the data files it lists) after every add(), so a stopped
//   run leaves a collection of the files it wrote. Entries are file names relative to the collection's directory.
// - DirectoryLock: one run's exclusive claim on its output directory, flock(2) on DIR/run.lock,
//   held until destruction. The system drops it when the holding process ends however it ends, so
//   a killed run leaves no stale lock. The file names the holder's process id. A second claim on a
//   held directory, from another process or the same one, throws OutputError naming the directory
//   and the holder at once (it never waits): two runs writing one directory would interleave their
//   files.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace demfem::adapter {

class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// How far a file's bytes have gone when its write returns (see contract).
enum class Durability {
  Synced,    // on the device (fsync): survives a power loss
  Unsynced,  // in the system's page cache: survives the process, not the machine
};

// Writes `bytes` to `file` atomically (see contract). Throws OutputError.
void writeFileAtomically(const std::filesystem::path& file, std::string_view bytes, Durability durability = Durability::Synced);

class CheckedFile {
 public:
  enum class Mode { Truncate, Append };
  // Opens (creating) `file`; Append keeps its first `keep_bytes` bytes and drops the rest (resume).
  // Throws OutputError if it cannot be opened or is shorter than keep_bytes.
  CheckedFile(std::filesystem::path file, Mode mode, std::uint64_t keep_bytes = 0);
  ~CheckedFile();  // closes without checking: call close() to learn whether everything arrived
  CheckedFile(const CheckedFile&) = delete;
  CheckedFile& operator=(const CheckedFile&) = delete;

  void write(std::string_view bytes);
  std::uint64_t size() const { return size_; }  // bytes in the file
  void sync();                                  // fsync: the bytes are on the device
  void close(Durability durability = Durability::Synced);  // (sync +) close; idempotent
  bool isOpen() const { return fd_ >= 0; }
  const std::filesystem::path& path() const { return path_; }

 private:
  [[noreturn]] void fail(const std::string& what) const;
  std::filesystem::path path_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

class DirectoryLock {
 public:
  static constexpr const char* kFileName = "run.lock";
  explicit DirectoryLock(const std::filesystem::path& directory);  // creates the directory if needed
  ~DirectoryLock();
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;

 private:
  int fd_ = -1;
};

// Renames `from` to `to`; throws OutputError naming both.
void renameChecked(const std::filesystem::path& from, const std::filesystem::path& to);

class VtkSeries {
 public:
  // The collection `pvd_file`; with `resume_until_s`, the entries of an existing collection at times
  // before it are kept (a resumed run continues the series), otherwise the collection starts empty.
  explicit VtkSeries(std::filesystem::path pvd_file, std::optional<double> resume_until_s = std::nullopt);
  // Adds `data_file` (in the collection's directory) at simulated time `time_s` and rewrites the
  // collection. Throws OutputError.
  void add(double time_s, const std::string& data_file);
  const std::vector<std::pair<double, std::string>>& entries() const { return entries_; }

 private:
  std::filesystem::path pvd_;
  std::vector<std::pair<double, std::string>> entries_;
};

}  // namespace demfem::adapter
