// Share of the FEM client in a coupled run (fem/coupled_driver.hpp) on a study's bin with the built-in
// DEM, per FEM step: the DEM's own time (measured where it runs: the server's thread when remote),
// the client's FEM step (integrator, sensors, the driver: its wall time outside every coupling call),
// the protocol (what the client waits on its calls beyond the DEM's time)
// and the step's outputs where they hold the run up (in process; remote they run during the DEM's
// interval, CouplingApi::advance, and cost the run nothing unless longer than it), with the processor
// time of the whole process over the run's wall time beside them. For the full and
// the modal integration (study fem.integration; --integrations) and the DEM in the client's process
// or served over ipc:// from a thread of its own as demfem-dem serves it (--placements), in
// interleaved rounds on the same settled soil; the DEM runs on the study's dem.threads. Prints a
// table of medians over the rounds; --json writes the same.
#include "bench_statistics.hpp"
#include "demfem/adapter/forwarding_api.hpp"
#include "demfem/adapter/remote_proxy.hpp"
#include "demfem/adapter/server.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/study/study.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>
#include <unistd.h>

namespace {

using namespace demfem;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

double processCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Wall time spent inside calls. Wall time only: reading a thread's processor time is a system call
// (1.5 us on the 2-core VM of docs/fem.md), a third of the FEM step it would time.
struct Clocks {
  double wall_s = 0;
};

class Scope {
 public:
  explicit Scope(Clocks& c) : clocks_(c) {}
  ~Scope() { clocks_.wall_s += std::chrono::duration<double>(Clock::now() - t0_).count(); }
  Scope(const Scope&) = delete;
  Scope& operator=(const Scope&) = delete;

 private:
  Clocks& clocks_;
  Clock::time_point t0_ = Clock::now();
};

// What the client's side of a coupling saw: the wall time inside its calls, of its own work run inside
// advance() (the step's outputs), and between two advance calls (its FEM steps).
struct ClientClocks {
  Clocks calls, work;
  Clocks between_advances;  // from each advance's return to the next advance's call
  std::int64_t advances = 0;
};

// Adds the wall time of every call to `seen.calls`, of the client's work that advance() runs (the
// step's outputs) to `seen.work` as well, and of the gaps between advance calls to
// `seen.between_advances`. advance() is forwarded as one call, so a
// remote proxy below still overlaps that work with the DEM's interval. Placed on the client's side
// it times what the client waits for (in process, calls - work is the DEM's own time); on the
// server's thread, the DEM's own time.
class TimedApi final : public adapter::ForwardingApi {
 public:
  explicit TimedApi(adapter::CouplingApi& inner) : ForwardingApi(inner) {}
  TimedApi(const TimedApi&) = delete;
  TimedApi& operator=(const TimedApi&) = delete;
  ClientClocks seen;

  adapter::BackendInfo info() override { Scope s(seen.calls); return inner().info(); }
  std::vector<adapter::GeometryInfo> geometries() override { Scope s(seen.calls); return inner().geometries(); }
  double time() override { Scope s(seen.calls); return inner().time(); }
  adapter::NodeArray nodePositions(const std::string& g) override { Scope s(seen.calls); return inner().nodePositions(g); }
  adapter::NodeArray nodeForces(const std::string& g, adapter::ForceMode m) override { Scope s(seen.calls); return inner().nodeForces(g, m); }
  void setNodePositions(const std::string& g, const adapter::NodeArray& x) override { Scope s(seen.calls); inner().setNodePositions(g, x); }
  void simulate(double d) override { Scope s(seen.calls); inner().simulate(d); }
  adapter::NodeArray advance(const std::string& g, const adapter::NodeArray& x, double d, adapter::ForceMode m,
                             const std::function<void()>& client_work) override {
    const auto entry = Clock::now();
    if (seen.advances > 0) seen.between_advances.wall_s += std::chrono::duration<double>(entry - last_advance_end_).count();
    ++seen.advances;
    adapter::NodeArray forces;
    {
      Scope s(seen.calls);
      forces = client_work ? inner().advance(g, x, d, m,
                                             [&] {
                                               Scope w(seen.work);
                                               client_work();
                                             })
                           : inner().advance(g, x, d, m, {});
    }
    last_advance_end_ = Clock::now();
    return forces;
  }
  adapter::RigidMotion rigidMotion(const std::string& g) override { Scope s(seen.calls); return inner().rigidMotion(g); }
  void setRigidMotion(const std::string& g, const adapter::RigidMotion& m) override { Scope s(seen.calls); inner().setRigidMotion(g, m); }
  void checkpoint(const fs::path& f) override { Scope s(seen.calls); inner().checkpoint(f); }
  void restore(const fs::path& f) override { Scope s(seen.calls); inner().restore(f); }

 private:
  Clock::time_point last_advance_end_;
};

// One run's clocks, per FEM step: the DEM's own time, the client's FEM step (integrator, sensors,
// the driver: the client's time between two advance calls), the step's outputs where they hold the
// run up (in process; remote they run during the DEM's interval), and the rest of the client's wait
// on its calls: the protocol (and any output the interval did not hide). What is left of the run's
// wall time is its opening and closing, once per run (keypoint matching, the output files opened,
// and closed durably: the keypoint displacement record alone is 41 MB on the quick study).
struct RunCost {
  std::int64_t steps = 0;
  double reduction_s = 0;  // the driver's construction (Eq 11-15 and the integrator set-up)
  Clocks total;            // driver.run() on the client's thread
  double process_cpu_s = 0;  // processor time of every thread of this process during driver.run()
  ClientClocks client;     // seen from the client (its FEM steps: all but the first, which follows the opening)
  Clocks dem;              // the DEM's own time where it runs (without the client's work)
  bool outputs_inline = true;
  double perStep_ms(double s) const { return 1e3 * s / static_cast<double>(steps); }
  double femStepMean_s() const {
    return client.between_advances.wall_s / static_cast<double>(std::max<std::int64_t>(1, client.advances - 1));
  }
  double femSteps_s() const { return femStepMean_s() * static_cast<double>(steps); }
  double openClose_s() const { return std::max(0.0, total.wall_s - client.calls.wall_s - client.between_advances.wall_s); }
  double stepping_s() const { return total.wall_s - openClose_s(); }
  double outputs_s() const { return outputs_inline ? client.work.wall_s : 0.0; }
  double protocol_s() const { return std::max(0.0, client.calls.wall_s - outputs_s() - dem.wall_s); }
};

enum class Placement { InProcess, Remote };

std::string placementName(Placement p) {
  switch (p) {
    case Placement::InProcess: return "in-process";
    case Placement::Remote: return "remote";
  }
  return {};
}

struct RemoteClocks {
  std::int64_t steps = 0;
  ClientClocks client;  // around the proxy
};

// The driver against `dem` served over ipc:// from a thread of this process (as demfem-dem serves it).
RemoteClocks runRemote(fem::CoupledDriver& driver, adapter::CouplingApi& dem, const fs::path& out) {
  fs::create_directories(out);
  protocol::Context context;
  protocol::ServerSocket socket(context, "ipc://" + (out / "dem.ipc").string());
  adapter::Server server(dem);
  std::thread serving([&] {
    try {
      server.serve(socket, std::chrono::seconds(60));
    } catch (const adapter::CouplingError& e) {
      std::fprintf(stderr, "DEM server: %s\n", e.what());
    }
  });
  RemoteClocks clocks;
  try {
    adapter::RemoteOptions remote;
    remote.endpoint = socket.endpoint();
    remote.client_name = "demfem-bench-coupled";
    adapter::RemoteProxy proxy(remote, &context);
    TimedApi client(proxy);
    clocks.steps = driver.run(client).steps;
    clocks.client = client.seen;
    proxy.shutdown();
  } catch (...) {
    serving.join();
    throw;
  }
  serving.join();
  return clocks;
}

RunCost coupledRun(const study::Study& study, const fs::path& out, std::optional<std::int64_t> steps, Placement placement) {
  fem::CoupledRunOptions options;
  options.output_dir = out;
  options.max_steps = steps;
  RunCost cost;
  auto t0 = Clock::now();
  fem::CoupledDriver driver(study, options);
  cost.reduction_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto backend = builtin::makeBackend(study);  // the settled soil: deposited by the first run, read after
  t0 = Clock::now();
  const double c0 = processCpuSeconds();
  switch (placement) {
    case Placement::InProcess: {
      TimedApi client(*backend);
      cost.steps = driver.run(client).steps;
      cost.client = client.seen;
      cost.dem = {client.seen.calls.wall_s - client.seen.work.wall_s};
      break;
    }
    case Placement::Remote: {
      TimedApi server(*backend);  // on the server's thread: the DEM's own time
      const RemoteClocks remote = runRemote(driver, server, out);
      cost.steps = remote.steps;
      cost.client = remote.client;
      cost.dem = server.seen.calls;
      cost.outputs_inline = false;
      break;
    }
  }
  cost.total = {std::chrono::duration<double>(Clock::now() - t0).count()};
  cost.process_cpu_s = processCpuSeconds() - c0;
  return cost;
}

study::Study withIntegration(const fs::path& file, const std::string& integration) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  std::stringstream text;
  text << in.rdbuf();
  auto doc = nlohmann::json::parse(text.str());
  doc["fem"]["integration"] = integration;
  return study::parseStudy(doc.dump(), file.string());
}


}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-coupled: share of the FEM client in a coupled run on the built-in DEM, full against modal integration, DEM in process or remote"};
  app.name("demfem-bench-coupled");
  std::string study_file = std::string(DEMFEM_SOURCE_DIR) + "/studies/quick.json";
  int rounds = 1;
  std::int64_t steps = 0;
  app.add_option("--study", study_file, "coupled study")->check(CLI::ExistingFile)->capture_default_str();
  app.add_option("--rounds", rounds, "interleaved rounds (one run of each variant)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--steps", steps, "FEM steps per run (0: the whole plan)")->check(CLI::NonNegativeNumber);
  std::vector<std::string> kinds{"full", "modal"};
  app.add_option("--integrations", kinds, "study fem.integration values timed in each round, in this order")
      ->check(CLI::IsMember({"full", "modal"}))
      ->capture_default_str();
  std::vector<Placement> placements{Placement::InProcess, Placement::Remote};
  app.add_option("--placements", placements, "where the DEM runs: in the client's process, or remote (served over ipc:// as demfem-dem serves it)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, Placement>{{"in-process", Placement::InProcess}, {"remote", Placement::Remote}}))
      ->capture_default_str();
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    const fs::path scratch = fs::temp_directory_path() / ("demfem-bench-coupled-" + std::to_string(getpid()));
    const std::optional<std::int64_t> max_steps = steps > 0 ? std::optional<std::int64_t>(steps) : std::nullopt;
    struct Variant {
      std::string integration;
      Placement placement;
      std::vector<RunCost> costs;
    };
    std::vector<Variant> variants;
    for (const auto& k : kinds)
      for (const auto p : placements) variants.push_back({k, p, {}});
    for (int r = 0; r < rounds; ++r)
      for (auto& v : variants) {
        std::fprintf(stderr, "round %d of %d: %s integration, DEM %s\n", r + 1, rounds, v.integration.c_str(),
                     placementName(v.placement).c_str());
        v.costs.push_back(coupledRun(withIntegration(study_file, v.integration), scratch / v.integration, max_steps, v.placement));
      }
    fs::remove_all(scratch);
    nlohmann::json rows = nlohmann::json::array();
    std::FILE* const table = cli::textStream(json_target);
    std::fprintf(table, "%-6s %-10s %6s %10s %11s %10s %10s %10s %10s %12s %10s %9s\n", "FEM", "DEM", "steps", "set-up(s)", "open+close(s)",
                "DEM(ms)", "FEM(ms)", "proto(ms)", "output(ms)", "FEM+proto(%)", "output(%)", "cpu/wall");
    for (const auto& v : variants) {
      std::vector<double> setup, open_close, dem_ms, fem_ms, protocol_ms, outputs_ms, fem_share, outputs_share, cpu_per_wall;
      for (const RunCost& c : v.costs) {
        setup.push_back(c.reduction_s);
        open_close.push_back(c.openClose_s());
        dem_ms.push_back(c.perStep_ms(c.dem.wall_s));
        fem_ms.push_back(1e3 * c.femStepMean_s());
        protocol_ms.push_back(c.perStep_ms(c.protocol_s()));
        outputs_ms.push_back(c.perStep_ms(c.outputs_s()));
        fem_share.push_back(100 * (c.femSteps_s() + c.protocol_s()) / c.stepping_s());
        outputs_share.push_back(100 * c.outputs_s() / c.stepping_s());
        cpu_per_wall.push_back(c.process_cpu_s / c.total.wall_s);
      }
      const std::string placement = placementName(v.placement);
      std::fprintf(table, "%-6s %-10s %6lld %10.2f %11.2f %10.3f %10.4f %10.4f %10.4f %12.2f %10.2f %9.2f\n", v.integration.c_str(),
                  placement.c_str(), static_cast<long long>(v.costs.front().steps), bench::median(setup),
                  bench::median(open_close), bench::median(dem_ms), bench::median(fem_ms), bench::median(protocol_ms),
                  bench::median(outputs_ms), bench::median(fem_share), bench::median(outputs_share),
                  bench::median(cpu_per_wall));
      rows.push_back({{"integration", v.integration},
                      {"dem", placement},
                      {"steps", v.costs.front().steps},
                      {"setup_s", bench::median(setup)},
                      {"open_close_s", bench::median(open_close)},
                      {"dem_per_step_ms", bench::median(dem_ms)},
                      {"fem_step_per_step_ms", bench::median(fem_ms)},
                      {"protocol_per_step_ms", bench::median(protocol_ms)},
                      {"outputs_inline_per_step_ms", bench::median(outputs_ms)},
                      {"fem_and_protocol_wall_percent", bench::median(fem_share)},
                      {"outputs_inline_wall_percent", bench::median(outputs_share)},
                      {"process_cpu_per_wall", bench::median(cpu_per_wall)}});
    }
    cli::writeJson(json_target, {{"study", study_file}, {"rounds", rounds}, {"runs", rows}});
  });
  return cli::runApp(app, argc, argv);
}
