// `demfem-fem run STUDY --connect ENDPOINT`: the coupled cycle of Fig. 3 against a DEM server.
#include "demfem/adapter/remote_proxy.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/fem/reduction_cache.hpp"
#include "demfem/protocol/transport.hpp"
#include "demfem/study/study.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <thread>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>

namespace demfem::cli {

namespace {

std::atomic<int> g_stop_signal{0};

extern "C" void onStopSignal(int signal) { g_stop_signal = signal; }

struct RunOptions {
  std::string study_file;
  std::string endpoint;
  std::string curve_keys;
  std::string output_dir;
  std::string wait_for;  // file whose appearance says the DEM server serves (demfem run)
  double timeout_s = 0;
  std::int64_t steps = 0;
  std::int64_t checkpoint_every = 0;
  bool resume = false;
  bool quiet = false;
};

// The text summary of a run (standard output; not with --json -).
void printSummary(const study::Study& study, const fem::CoupledRunSummary& summary, const std::filesystem::path& output_dir) {
  if (summary.complete)
    std::printf("coupled run of '%s' against DEM backend '%s' complete (%s tool)\n", study.name.c_str(),
                summary.backend.c_str(), summary.rigid_tool ? "rigid" : "deformable");
  else
    std::printf("coupled run of '%s' against DEM backend '%s' %s (%s tool): outputs marked incomplete\n",
                study.name.c_str(), summary.backend.c_str(), summary.incomplete_reason.c_str(),
                summary.rigid_tool ? "rigid" : "deformable");
  std::printf("  FEM steps            %lld of %lld (%lld in the drag phase)\n", static_cast<long long>(summary.steps),
              static_cast<long long>(summary.planned_steps), static_cast<long long>(summary.drag_steps));
  std::printf("  simulated time       %.6g s\n", summary.simulated_time_s);
  std::printf("  wall time            %.3g s\n", summary.wall_time_s);
  std::printf("  mean load-cell force %.6g N (max %.6g N)\n", summary.mean_force_N, summary.max_force_N);
  std::printf("  final deformation    %.6g mm, tilt %.6g deg\n", summary.final_deformation_mm, summary.final_tilt_deg);
  std::printf("  outputs              %s\n", output_dir.string().c_str());
}

void runCoupledCommand(const RunOptions& o, const std::string& json_target) {
  const study::Study study = study::loadStudy(o.study_file);
  const std::string endpoint = !o.endpoint.empty() ? o.endpoint : study.coupling.endpoint;
  if (endpoint.empty()) throw InputError("no DEM server to connect to: pass --connect ENDPOINT (the study has no coupling.endpoint)");

  adapter::RemoteOptions remote;
  remote.endpoint = endpoint;
  remote.timeout = std::chrono::milliseconds(static_cast<std::int64_t>(1000 * (o.timeout_s > 0 ? o.timeout_s : study.coupling.timeout_s)));
  if (!o.curve_keys.empty()) remote.security = protocol::loadClientSecurity(o.curve_keys);
  remote.client_name = "demfem-fem " + study.name;

  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);

  fem::CoupledRunOptions options;
  options.output_dir = !o.output_dir.empty() ? std::filesystem::path(o.output_dir) : study.output.directory;
  if (o.steps > 0) options.max_steps = o.steps;
  options.checkpoint_every = o.checkpoint_every;
  options.resume = o.resume;
  options.stop_requested = [] { return g_stop_signal != 0; };
  Progress reduction("FEM model (keypoint reduction, integrator set-up)", !o.quiet);
  options.on_reduction_progress = [&reduction](double fraction) { reduction.update(fraction); };
  options.reduction_cache_dir = fem::defaultReductionDirectory();
  std::optional<Progress> coupled;  // started once the model is built
  options.on_progress = [&coupled](const fem::CoupledProgress& p) {
    char detail[96];
    std::snprintf(detail, sizeof detail, "step %lld/%lld, t = %.4f of %.4f s, %.0f steps/s", static_cast<long long>(p.step),
                  static_cast<long long>(p.total_steps), p.time_s, p.end_time_s, p.steps_per_s);
    coupled->update(p.total_steps ? static_cast<double>(p.step) / static_cast<double>(p.total_steps) : 1.0, detail);
  };

  fem::CoupledDriver driver(study, options);  // FEM model first: the DEM server's idle clock is not running yet
  reduction.finish();
  // Started beside the DEM server (demfem run), the reduction overlapped its deposition: wait until it serves.
  while (!o.wait_for.empty() && !std::filesystem::exists(o.wait_for)) {
    if (const int signal = g_stop_signal) {
      std::signal(signal, SIG_DFL);
      std::raise(signal);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  coupled.emplace("coupled run", !o.quiet);
  adapter::RemoteProxy dem(remote);
  fem::CoupledRunSummary summary;
  try {
    summary = driver.run(dem);
  } catch (const std::exception& e) {
    try {
      dem.shutdown();
    } catch (const std::exception&) {
      // the DEM side may be what failed; its own error is the one to report
    }
    if (const int signal = g_stop_signal) {
      std::cerr << "demfem-fem: interrupted; outputs in " << options.output_dir.string() << " marked incomplete\n";
      std::signal(signal, SIG_DFL);
      std::raise(signal);  // exit by the signal, as a shell expects
    }
    throw std::runtime_error(std::string(e.what()) + " (outputs in " + options.output_dir.string() +
                             "; their sensors.json says they are incomplete)");
  }
  dem.shutdown();
  coupled->finish();

  if (textOnStdout(json_target)) printSummary(study, summary, options.output_dir);
  writeJson(json_target, {{"study", study.name},
                          {"backend", summary.backend},
                          {"rigid_tool", summary.rigid_tool},
                          {"complete", summary.complete},
                          {"incomplete_reason", summary.incomplete_reason},
                          {"steps", summary.steps},
                          {"planned_steps", summary.planned_steps},
                          {"drag_steps", summary.drag_steps},
                          {"simulated_time_s", summary.simulated_time_s},
                          {"wall_time_s", summary.wall_time_s},
                          {"mean_force_N", summary.mean_force_N},
                          {"max_force_N", summary.max_force_N},
                          {"final_deformation_mm", summary.final_deformation_mm},
                          {"final_tilt_deg", summary.final_tilt_deg},
                          {"output_dir", options.output_dir.string()}});
}

}  // namespace

void addFemRunCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("run", "Coupled run (Fig. 3) of a study against a DEM server (demfem-dem)");
  auto o = std::make_shared<RunOptions>();
  cmd->add_option("study", o->study_file, "Study file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--connect", o->endpoint, "DEM server endpoint (tcp://HOST:PORT, ipc://PATH); default: the study's coupling.endpoint");
  cmd->add_option("--curve-keys", o->curve_keys, "CurveZMQ key directory (server.pub, client.pub, client.secret)")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--output,--out", o->output_dir, "Output directory; default: the study's output.directory");
  cmd->add_option("--timeout-s", o->timeout_s, "Seconds to wait for any DEM reply; default: the study's coupling.timeout_s")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--steps", o->steps, "Stop after this many FEM steps (insertion + drag; outputs then marked incomplete); default: the whole plan")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "Write a coupled checkpoint every N FEM steps")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--resume", o->resume, "Resume from the checkpoint in the output directory");
  cmd->add_option("--wait-for", o->wait_for,
                  "Build the FEM model, then wait until this file exists before connecting (the DEM server's endpoint file)");
  cmd->add_flag("--quiet", o->quiet, "No progress output");
  std::string& json = addJsonOption(*cmd);
  cmd->callback([o, &json] { runCoupledCommand(*o, json); });
}

}  // namespace demfem::cli
