#include "demfem/adapter/output_files.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>
#include <thread>

namespace demfem::adapter {

namespace fs = std::filesystem;

namespace {

std::string reason(int error) { return std::strerror(error); }

std::string timeText(double t) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", t);
  return text;
}

}  // namespace

CheckedFile::CheckedFile(fs::path file, Mode mode, std::uint64_t keep_bytes) : path_(std::move(file)) {
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (mode == Mode::Truncate ? O_TRUNC : 0);
  fd_ = ::open(path_.c_str(), flags, 0644);
  if (fd_ < 0) fail("cannot open for writing");
  if (mode == Mode::Append) {
    struct stat st {};
    if (::fstat(fd_, &st) != 0) fail("cannot read its size");
    if (static_cast<std::uint64_t>(st.st_size) < keep_bytes)
      throw OutputError(path_.string() + ": has " + std::to_string(st.st_size) + " bytes, expected at least " +
                        std::to_string(keep_bytes));
    if (::ftruncate(fd_, static_cast<off_t>(keep_bytes)) != 0) fail("cannot cut back to " + std::to_string(keep_bytes) + " bytes");
    if (::lseek(fd_, 0, SEEK_END) < 0) fail("cannot seek to its end");
    size_ = keep_bytes;
  }
}

CheckedFile::~CheckedFile() {
  if (fd_ >= 0) ::close(fd_);
}

void CheckedFile::fail(const std::string& what) const {
  throw OutputError("writing " + path_.string() + " failed: " + what + " (" + reason(errno) + ")");
}

void CheckedFile::write(std::string_view bytes) {
  if (fd_ < 0) throw OutputError("writing " + path_.string() + " failed: the file is closed");
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd_, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = ENOSPC;
      fail("write of " + std::to_string(bytes.size()) + " bytes at offset " + std::to_string(size_));
    }
    bytes.remove_prefix(static_cast<std::size_t>(n));
    size_ += static_cast<std::uint64_t>(n);
  }
}

void CheckedFile::sync() {
  if (fd_ >= 0 && ::fsync(fd_) != 0 && errno != EINVAL) fail("sync");
}

void CheckedFile::close(Durability durability) {
  if (fd_ < 0) return;
  switch (durability) {
    case Durability::Synced: sync(); break;
    case Durability::Unsynced: break;
  }
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) fail("close");
}

DirectoryLock::DirectoryLock(const fs::path& directory) {
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) throw OutputError("cannot create the output directory " + directory.string() + " (" + ec.message() + ")");
  const fs::path file = directory / kFileName;
  fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw OutputError(file.string() + ": cannot open the run lock (" + reason(errno) + ")");
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    char holder[32] = {};
    const ssize_t n = ::pread(fd_, holder, sizeof holder - 1, 0);
    ::close(fd_);
    if (error == EWOULDBLOCK)
      throw OutputError(directory.string() + " is in use by another run (process " + (n > 0 ? std::string(holder, n) : std::string("unknown")) +
                        "); wait for it to end or choose another output directory");
    throw OutputError(file.string() + ": cannot lock (" + reason(error) + ")");
  }
  const std::string pid = std::to_string(::getpid());
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    const int error = errno;
    ::close(fd_);
    throw OutputError(file.string() + ": cannot write the run lock (" + reason(error) + ")");
  }
}

DirectoryLock::~DirectoryLock() { ::close(fd_); }  // closing the descriptor drops the lock

void renameChecked(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) throw OutputError("renaming " + from.string() + " to " + to.string() + " failed (" + ec.message() + ")");
}

void writeFileAtomically(const fs::path& file, std::string_view bytes, Durability durability) {
  // One temporary per process and thread: concurrent writers of one file never share it.
  std::ostringstream tag;
  tag << ::getpid() << '-' << std::this_thread::get_id();
  const fs::path tmp = file.string() + "." + tag.str() + ".partial";
  try {
    CheckedFile out(tmp, CheckedFile::Mode::Truncate);
    out.write(bytes);
    out.close(durability);
    renameChecked(tmp, file);
  } catch (const OutputError&) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

VtkSeries::VtkSeries(fs::path pvd_file, std::optional<double> resume_until_s) : pvd_(std::move(pvd_file)) {
  if (!resume_until_s) return;
  std::ifstream in(pvd_);
  std::string line;
  while (std::getline(in, line)) {
    const auto t = line.find("timestep=\""), f = line.find("file=\"");
    if (t == std::string::npos || f == std::string::npos) continue;
    const double time = std::stod(line.substr(t + 10));
    const std::string name = line.substr(f + 6, line.find('"', f + 6) - (f + 6));
    if (time < *resume_until_s) entries_.emplace_back(time, name);
  }
}

void VtkSeries::add(double time_s, const std::string& data_file) {
  entries_.emplace_back(time_s, data_file);
  std::ostringstream s;
  s << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n";
  for (const auto& [t, name] : entries_)
    s << "    <DataSet timestep=\"" << timeText(t) << "\" part=\"0\" file=\"" << name << "\"/>\n";
  s << "  </Collection>\n</VTKFile>\n";
  writeFileAtomically(pvd_, s.str(), Durability::Unsynced);
}

}  // namespace demfem::adapter
