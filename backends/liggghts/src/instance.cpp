// One LIGGGHTS instance (session.hpp): construction with its output kept in the work directory,
// commands, and the report of a LIGGGHTS exit() on a failed command.
#include "session.hpp"

#include <mpi.h>

#include <input.h>
#include <lammps.h>
#include <library.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <fcntl.h>
#include <unistd.h>

namespace demfem::liggghts::detail {

namespace {

// Redirects the process's stderr (file descriptor 2) into a file for its lifetime.
class StderrToFile {
 public:
  explicit StderrToFile(const std::filesystem::path& file) {
    std::fflush(stderr);
    saved_ = ::dup(2);
    const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (saved_ >= 0 && fd >= 0) ::dup2(fd, 2);
    if (fd >= 0) ::close(fd);
  }
  ~StderrToFile() {
    std::fflush(stderr);
    if (saved_ >= 0) {
      ::dup2(saved_, 2);
      ::close(saved_);
    }
  }
  StderrToFile(const StderrToFile&) = delete;
  StderrToFile& operator=(const StderrToFile&) = delete;

 private:
  int saved_ = -1;
};

// LIGGGHTS reports an input or run-time error by printing it to its screen file and calling exit().
// While a command runs, this names it and the screen file, so that an exit handler can tell the user
// what LIGGGHTS said (the screen file is in the work directory, not on the terminal).
struct CommandInFlight {
  std::string command;
  std::filesystem::path screen;
};
CommandInFlight* command_in_flight = nullptr;

void reportLiggghtsExit() {
  if (!command_in_flight) return;
  std::string message = "LIGGGHTS stopped the process";
  std::ifstream screen(command_in_flight->screen);
  for (std::string line; std::getline(screen, line);)
    if (line.rfind("ERROR", 0) == 0) message = line;
  std::fprintf(stderr, "demfem liggghts backend: while running `%s`: %s (full output: %s)\n",
               command_in_flight->command.c_str(), message.c_str(), command_in_flight->screen.c_str());
}

}  // namespace

std::string exact(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

Instance::Instance(const std::filesystem::path& work_dir, const std::string& name)
    : screen_(work_dir / (name + "-screen.txt")) {
  const std::string screen = screen_.string();
  const std::string log = (work_dir / (name + ".log")).string();
  const char* args[] = {"liggghts", "-echo", "none", "-screen", screen.c_str(), "-log", log.c_str()};
  // Every instance after the first in a process re-registers LIGGGHTS' contact-model styles and
  // prints hundreds of "Style collision" warnings to stderr: keep them in the work directory.
  const StderrToFile quiet(work_dir / (name + "-construction.txt"));
  lmp_ = new LAMMPS_NS::LAMMPS(7, const_cast<char**>(args), MPI_COMM_WORLD);
}

Instance::~Instance() { delete lmp_; }

void Instance::command(const std::string& line) {
  static const bool handler_registered = std::atexit(reportLiggghtsExit) == 0;
  (void)handler_registered;
  CommandInFlight in_flight{line, screen_};
  command_in_flight = &in_flight;
  lmp_->input->one(line.c_str());
  command_in_flight = nullptr;
}

double Instance::computeScalar(const char* id) {
  return *static_cast<double*>(lammps_extract_compute(lmp_, const_cast<char*>(id), 0, 0));
}

}  // namespace demfem::liggghts::detail
