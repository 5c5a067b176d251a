// demfem-dem: the DEM adapter server. Builds a DEM backend (built-in, LIGGGHTS or an analytic test
// backend) and serves it over the demfem protocol until the FEM client shuts it down.
#include "demfem/adapter/output_files.hpp"
#include "demfem/adapter/server.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#include "demfem/cli/soil_supply.hpp"
#include "demfem/protocol/transport.hpp"
#include "demfem/study/study.hpp"

#include <fstream>
#include <iostream>

namespace {

using namespace demfem;

struct Options {
  std::string backend;
  std::string study_file;
  std::string bind;
  std::string curve_keys;
  std::string make_curve_keys;
  bool insecure = false;
  std::string endpoint_file;
  std::string checkpoint_dir;
  double max_simulate_s = 0;  // 0: the study's coupling.max_simulate_s
  std::string output_dir;
  double connect_timeout_s = 600;
  double idle_timeout_s = 0;  // 0: the study's coupling timeout x 2
  int threads = 0;            // 0: the study's dem.threads
  bool allow_unsettled_soil = false;
  adapter::TestLoad load;
};

std::chrono::milliseconds millis(double seconds) {
  return std::chrono::milliseconds(static_cast<std::int64_t>(seconds * 1000.0));
}

std::unique_ptr<adapter::CouplingApi> makeBackend(const Options& o, const cli::BackendEntry& backend,
                                                   const std::optional<study::Study>& study) {
  if (!backend.capabilities.simulates_soil) return backend.make(study, o.load);
  const std::string& name = backend.capabilities.name;
  if (!study) throw cli::InputError("--study is required for the '" + name + "' backend");
  return cli::openSoilBackend(backend, *study, o.allow_unsettled_soil);
}

void run(const Options& o) {
  if (!o.make_curve_keys.empty()) {
    protocol::writeCurveKeyDirectory(o.make_curve_keys);
    std::cout << "demfem-dem: wrote CurveZMQ keys to " << o.make_curve_keys
              << " (server.pub/.secret stay with the DEM server, client.pub/.secret go to the FEM client; "
                 "both need server.pub and client.pub)\n";
    return;
  }
  std::optional<study::Study> study;
  if (!o.study_file.empty()) study = cli::loadCheckedStudy(o.study_file);
  if (o.threads > 0 && study) study->dem.threads = o.threads;
  if (study && !o.output_dir.empty()) study->output.directory = o.output_dir;
  const std::string backend = !o.backend.empty() ? o.backend : study ? study->dem.backend : study::DemSettings{}.backend;
  const cli::BackendEntry& entry = cli::findBackend(backend);
  if (entry.follow) {
    if (!study) throw cli::InputError("--study is required for the '" + backend + "' backend");
    if (entry.follow(*study)) return;
  }
  std::string endpoint = o.bind;
  if (endpoint.empty()) endpoint = study && !study->coupling.endpoint.empty() ? study->coupling.endpoint : "tcp://127.0.0.1:5555";
  const double idle_s = o.idle_timeout_s > 0 ? o.idle_timeout_s : 2.0 * (study ? study->coupling.timeout_s : 30.0);

  protocol::ServerSocketOptions socket_options;
  if (!o.curve_keys.empty()) socket_options.security = protocol::loadServerSecurity(o.curve_keys);
  socket_options.insecure_tcp = o.insecure;
  const auto log = [](const std::string& text) { std::cerr << "demfem-dem: " << text << std::endl; };
  socket_options.log = log;
  const bool secure = socket_options.security.has_value();
  try {
    protocol::checkBindEndpoint(endpoint, secure, o.insecure);
  } catch (const std::invalid_argument& e) {
    throw cli::InputError(std::string("--bind: ") + e.what());
  }
  auto api = makeBackend(o, entry, study);
  protocol::Context context;
  protocol::ServerSocket socket(context, endpoint, std::move(socket_options));
  if (!o.endpoint_file.empty()) {
    adapter::writeFileAtomically(o.endpoint_file, socket.endpoint() + "\n");
  }
  std::cerr << "demfem-dem: serving backend '" << backend << "' on " << socket.endpoint()
            << (secure                                ? " (CurveZMQ)"
                : endpoint.rfind("tcp://", 0) == 0 ? " (--insecure: no authentication, any local process may connect)"
                                                    : "")
            << std::endl;
  adapter::ServerOptions options;
  options.idle_timeout = millis(idle_s);
  options.max_simulate_s = o.max_simulate_s > 0 ? o.max_simulate_s
                           : study                ? study->coupling.max_simulate_s
                                                  : study::kDefaultMaxSimulateS;
  if (!o.checkpoint_dir.empty()) {
    std::filesystem::create_directories(o.checkpoint_dir);
    options.checkpoint_dir = std::filesystem::canonical(o.checkpoint_dir);
  }
  options.log = log;
  adapter::Server server(*api, options);
  server.serve(socket, millis(o.connect_timeout_s));
  std::cerr << "demfem-dem: shut down by the client" << std::endl;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-dem: DEM adapter server of demfem. Serves a DEM backend over the demfem protocol "
               "(docs/protocol.md) to one FEM client until it shuts the backend down."};
  app.name("demfem-dem");
  Options o;
  std::string backends;
  for (const cli::BackendEntry& e : cli::backendRegistry())
    backends += (backends.empty() ? "" : " | ") + e.capabilities.name + (e.capabilities.simulates_soil ? "" : " (test)");
  app.add_option("--backend", o.backend, backends + "; default: the study's dem.backend, else builtin");
  app.add_option("--study", o.study_file, "Study file (JSON); optional for test backends (default plate tool)")
      ->check(CLI::ExistingFile);
  app.add_option("--bind", o.bind,
                 "Endpoint to serve: tcp://127.0.0.1:PORT (PORT * = any free port), ipc://PATH; default: the study's "
                 "coupling.endpoint, else tcp://127.0.0.1:5555. tcp needs --curve-keys (or --insecure on a loopback address)");
  app.add_option("--curve-keys", o.curve_keys, "CurveZMQ key directory (server.pub, server.secret, client.pub)")
      ->check(CLI::ExistingDirectory);
  app.add_flag("--insecure", o.insecure,
               "Serve tcp on a loopback address without CurveZMQ keys: any local process can then connect, take "
               "the session before your client or flood the server (docs/protocol.md)");
  app.add_option("--make-curve-keys", o.make_curve_keys, "Write a fresh server and client key pair to DIR and exit");
  app.add_option("--threads", o.threads, "threads of the built-in DEM; default: the study's dem.threads (the machine's cores)")
      ->check(CLI::PositiveNumber);
  app.add_option("--endpoint-file", o.endpoint_file, "Write the bound endpoint (with the chosen port) to FILE");
  app.add_option("--checkpoint-dir", o.checkpoint_dir,
                 "Directory of the checkpoints the client names (created if missing); without it checkpoint and "
                 "restore are refused");
  app.add_option("--max-simulate-s", o.max_simulate_s,
                 "Longest simulate call accepted (s); default: the study's coupling.max_simulate_s, else 1")
      ->check(CLI::PositiveNumber);
  app.add_option("--output,--out", o.output_dir, "Directory of the DEM's own files (builtin: VTK); default: the study's output.directory");
  app.add_option("--connect-timeout-s", o.connect_timeout_s, "Give up if no client says hello within this time (s)")
      ->check(CLI::PositiveNumber);
  app.add_option("--idle-timeout-s", o.idle_timeout_s,
                 "Give up if the client sends nothing for this long (s); default: twice the study's coupling timeout")
      ->check(CLI::PositiveNumber);
  cli::addAllowUnsettledSoilFlag(app, o.allow_unsettled_soil);
  app.add_option("--test-force-N", o.load.force_N, "Test backends: total tip-row force F along local z (N)");
  app.add_option("--test-frequency-Hz", o.load.frequency_Hz, "Harmonic test backend: frequency f (Hz)");
  app.add_option("--test-stiffness-N-m", o.load.stiffness_N_m, "Spring test backend: total tip-row stiffness k (N/m)");
  app.add_option("--test-dt-s", o.load.dem_time_step_s, "Test backends: DEM time step (s)")->check(CLI::PositiveNumber);
  app.callback([&] { run(o); });
  return demfem::cli::runApp(app, argc, argv);
}
