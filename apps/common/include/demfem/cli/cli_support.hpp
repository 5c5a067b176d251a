// Shared plumbing of the demfem executables: exit codes, exception-to-message mapping, --json output.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <functional>
#include <stdexcept>
#include <string>

namespace demfem::cli {

// Exit codes of every demfem executable.
enum ExitCode : int {
  kOk = 0,
  kFailure = 1,     // the computation failed (peer gone, blow-up, I/O error)
  kBadInput = 2,    // invalid study, recording, argument: the message says what and where
  kInterrupted = 130,
};

// Thrown for invalid user input that is not a study file (recordings, arguments): exit code 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Thrown when a stop request (Ctrl-C, SIGTERM) ended a command early: exit code 130.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses argv into `app` and runs the selected callbacks, turning every exception into one message
// on stderr (prefixed with the program name) and an exit code. Never lets an exception escape.
int runApp(CLI::App& app, int argc, char** argv);

// Adds `--json FILE` to `cmd` (FILE "-" = standard output); returns the bound string.
std::string& addJsonOption(CLI::App& cmd);

// Writes `doc` to `target` ("-" = stdout) atomically (temp file + rename). No-op if target empty.
void writeJson(const std::string& target, const nlohmann::json& doc);

}  // namespace demfem::cli
