// Shared plumbing of the demfem executables: exit codes, exception-to-message mapping, --json output.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <stdexcept>
#include <cstdio>
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

// Adds `--no-plots` (sets `no_plots`) and `--gnuplot PROGRAM` (default shown) to a command that
// draws `plots` (their description, e.g. "SVG and PNG plots").
void addPlotOptions(CLI::App& cmd, bool& no_plots, std::string& gnuplot, const std::string& plots);

// Adds `--allow-unsettled-soil` (sets `allow`): run even on a soil whose deposition did not settle
// (refused by default: adapter::unsettledReason; the soil's figures are recorded with the run).
void addAllowUnsettledSoilFlag(CLI::App& cmd, bool& allow);

// False when `--json -` claimed standard output: then the command prints nothing else there.
inline bool textOnStdout(const std::string& json_target) { return json_target != "-"; }

// Where a command's table for people goes: standard output, or standard error when `--json -`
// claimed standard output.
inline std::FILE* textStream(const std::string& json_target) { return textOnStdout(json_target) ? stdout : stderr; }

// Writes `doc` to `target` ("-" = stdout) atomically (temp file + rename). No-op if target empty.
void writeJson(const std::string& target, const nlohmann::json& doc);

// The JSON document in `file`, keys in file order. Throws InputError naming the file when it cannot
// be read or is not JSON (with the parser's message).
nlohmann::ordered_json readJsonFile(const std::filesystem::path& file);

}  // namespace demfem::cli
