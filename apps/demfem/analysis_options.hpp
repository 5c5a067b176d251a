// Options shared by `demfem evaluate`, `compare`, `calibrate` and `diagnose`: the Section 2.3
// settings, output directory, plots, the staged writing of the outputs, and turning analysis errors
// into exit codes.
#pragma once

#include "demfem/adapter/output_files.hpp"
#include "demfem/analysis/workflow.hpp"
#include "demfem/cli/cli_support.hpp"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <memory>
#include <regex>
#include <string>

namespace demfem::cli {

struct AnalysisOptions {
  analysis::AnalysisSettings settings;
  std::string end_signal = "force";
  std::string out_dir;
  std::string gnuplot = "gnuplot";
  bool no_plots = false;
};

inline void addAnalysisOptions(CLI::App& cmd, AnalysisOptions& options) {
  auto& e = options.settings.evaluation;
  cmd.add_option("--out,--output", options.out_dir, "Output directory (tables, evaluated curves, plots/, report.md)")->capture_default_str();
  cmd.add_option("--window-begin-mm", e.window_begin_mm, "Start of the statistics window in tool displacement (mm)")->capture_default_str();
  cmd.add_option("--window-end-mm", e.window_end_mm, "End of the statistics window in tool displacement (mm)")->capture_default_str();
  cmd.add_option("--end-at", options.end_signal, "Signal whose maximum ends a raw soil-bin run (Section 2.3)")
      ->check(CLI::IsMember({"force", "deformation"}))
      ->capture_default_str();
  cmd.add_option("--baseline-s", e.baseline_duration_s, "Leading span averaged for the initial deformation value (s)")->capture_default_str();
  addPlotOptions(cmd, options.no_plots, options.gnuplot, "SVG plots");
}

// Adds the analysis command `name` (`description`: its --help text) with the options above, the
// output directory `out_dir` by default, and `--json FILE`; returns the command and the JSON target.
struct AnalysisCommand {
  CLI::App* cmd;
  std::string* json_target;
};
inline AnalysisCommand addAnalysisCommand(CLI::App& app, const std::string& name, const std::string& description,
                                          AnalysisOptions& options, const std::string& out_dir) {
  options.out_dir = out_dir;
  CLI::App* cmd = app.add_subcommand(name, description);
  addAnalysisOptions(*cmd, options);
  return {cmd, &addJsonOption(*cmd)};
}

// Checks the option values; throws InputError (exit code 2) for inconsistent ones.
inline void finishAnalysisOptions(AnalysisOptions& options) {
  auto& e = options.settings.evaluation;
  e.end_signal = options.end_signal == "force" ? analysis::EndSignal::Force : analysis::EndSignal::Deformation;
  if (!(e.window_begin_mm >= 0.0 && e.window_end_mm > e.window_begin_mm))
    throw InputError("--window-begin-mm/--window-end-mm: need 0 <= begin < end, got " + std::to_string(e.window_begin_mm) + " and " +
                     std::to_string(e.window_end_mm));
  if (!(e.baseline_duration_s >= 0.0)) throw InputError("--baseline-s: must be >= 0");
}

// One command's exclusive claim on its output directory, held from before its first write to the
// end (adapter::DirectoryLock: a second command on the same directory fails at once with the
// holder's process id, instead of mixing its files with the first one's and both reporting
// success). Holding it, every temporary of an atomic write under the directory (FILE.<pid>.partial
// of analysis::StagedOutput, FILE.<pid>-<thread>.partial of adapter::writeFileAtomically) is a
// killed writer's and is removed; a run's resumable FILE.partial is not such a temporary and stays
// (docs/reliability.md, "One writer per output directory").
class OutputClaim {
 public:
  explicit OutputClaim(const std::filesystem::path& directory) : lock_(directory) {
    static const std::regex temporary(R"(.*\.[0-9]+(-[0-9]+)?\.partial)");
    std::vector<std::filesystem::path> stale;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(directory))
      if (entry.is_regular_file() && std::regex_match(entry.path().filename().string(), temporary)) stale.push_back(entry.path());
    for (const auto& path : stale) std::filesystem::remove(path);
  }

 private:
  adapter::DirectoryLock lock_;
};

// Writes a command's files through one staged output directory (options.out_dir; nothing appears
// under its final name unless `write` and the commit succeed): write(out, renderer), the renderer
// null under --no-plots. Returns the output directory.
template <class Write>
std::filesystem::path writeStaged(const AnalysisOptions& options, Write&& write) {
  analysis::StagedOutput out(options.out_dir);
  const analysis::GnuplotRenderer renderer(options.gnuplot);
  write(out, options.no_plots ? nullptr : &renderer);
  out.commit();
  return out.directory();
}

// Runs `body`, mapping the analysis library's input errors to the CLI's (exit code 2).
template <class Body>
void runAnalysis(Body&& body) {
  try {
    body();
  } catch (const analysis::InputError& e) {
    throw InputError(e.what());
  }
}

}  // namespace demfem::cli
