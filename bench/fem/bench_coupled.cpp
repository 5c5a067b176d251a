// Share of the FEM client in a coupled run (fem/coupled_driver.hpp) on a study's bin with the built-in
// DEM: the time spent inside the DEM's coupling calls against the rest (FEM step, sensors, outputs,
// and with a remote DEM the protocol), for the full and the modal integration (study
// fem.integration; --integrations picks them) and the DEM in the client's process or served over
// ipc:// from a thread of its own as demfem-dem serves it (--placements), in interleaved rounds on
// the same settled soil. The DEM's time is measured where it runs (the server's thread when
// remote), so a client's work overlapped with the DEM's interval (CouplingApi::advance) costs the
// run nothing. Wall time, and processor time of the client's and the DEM's calling threads; the DEM
// runs on the study's dem.threads. Prints a table; --json writes the same.
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

double threadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Time spent inside the DEM's calls (wall, and processor time of the calling thread).
struct Clocks {
  double wall_s = 0, cpu_s = 0;
};

// Adds the wall and thread processor time of every call to `inside`.
class TimedDem final : public adapter::ForwardingApi {
  struct Scope {
    explicit Scope(Clocks& c) : clocks(c) {}
    ~Scope() {
      clocks.wall_s += std::chrono::duration<double>(Clock::now() - t0).count();
      clocks.cpu_s += threadCpuSeconds() - c0;
    }
    Clocks& clocks;
    Clock::time_point t0 = Clock::now();
    double c0 = threadCpuSeconds();
  };

 public:
  explicit TimedDem(std::unique_ptr<adapter::CouplingApi> inner) : ForwardingApi(*inner), inner_(std::move(inner)) {}
  Clocks inside;

  adapter::BackendInfo info() override { Scope s(inside); return inner().info(); }
  std::vector<adapter::GeometryInfo> geometries() override { Scope s(inside); return inner().geometries(); }
  double time() override { Scope s(inside); return inner().time(); }
  adapter::NodeArray nodePositions(const std::string& g) override { Scope s(inside); return inner().nodePositions(g); }
  adapter::NodeArray nodeForces(const std::string& g, adapter::ForceMode m) override { Scope s(inside); return inner().nodeForces(g, m); }
  void setNodePositions(const std::string& g, const adapter::NodeArray& x) override { Scope s(inside); inner().setNodePositions(g, x); }
  void simulate(double d) override { Scope s(inside); inner().simulate(d); }
  // In process the client's work runs on this thread before the interval: it is not the DEM's.
  adapter::NodeArray advance(const std::string& g, const adapter::NodeArray& x, double d, adapter::ForceMode m,
                             const std::function<void()>& work) override {
    if (work) work();
    Scope s(inside);
    return inner().advance(g, x, d, m, {});
  }
  adapter::RigidMotion rigidMotion(const std::string& g) override { Scope s(inside); return inner().rigidMotion(g); }
  void setRigidMotion(const std::string& g, const adapter::RigidMotion& m) override { Scope s(inside); inner().setRigidMotion(g, m); }
  void checkpoint(const fs::path& f) override { Scope s(inside); inner().checkpoint(f); }
  void restore(const fs::path& f) override { Scope s(inside); inner().restore(f); }

 private:
  std::unique_ptr<adapter::CouplingApi> inner_;
};

struct RunCost {
  std::int64_t steps = 0;
  double reduction_s = 0;           // the driver's construction (Eq 11-15 and the integrator set-up)
  Clocks total, dem;
  double fem_cpu_s = 0;             // the client's processor time outside the DEM's calls
  double femWallShare() const { return (total.wall_s - dem.wall_s) / total.wall_s; }
  double femCpuShare() const { return fem_cpu_s / (fem_cpu_s + dem.cpu_s); }
};

enum class Placement { InProcess, Remote };

std::string placementName(Placement p) {
  switch (p) {
    case Placement::InProcess: return "in-process";
    case Placement::Remote: return "remote";
  }
  return {};
}

// The driver against `dem` served over ipc:// from a thread of this process (as demfem-dem serves it).
std::int64_t runRemote(fem::CoupledDriver& driver, adapter::CouplingApi& dem, const fs::path& out) {
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
  std::int64_t steps = 0;
  try {
    adapter::RemoteOptions remote;
    remote.endpoint = socket.endpoint();
    remote.client_name = "demfem-bench-coupled";
    adapter::RemoteProxy proxy(remote, &context);
    steps = driver.run(proxy).steps;
    proxy.shutdown();
  } catch (...) {
    serving.join();
    throw;
  }
  serving.join();
  return steps;
}

RunCost coupledRun(const study::Study& study, const fs::path& out, std::optional<std::int64_t> steps, Placement placement) {
  fem::CoupledRunOptions options;
  options.output_dir = out;
  options.max_steps = steps;
  RunCost cost;
  auto t0 = Clock::now();
  fem::CoupledDriver driver(study, options);
  cost.reduction_s = std::chrono::duration<double>(Clock::now() - t0).count();
  TimedDem dem(builtin::makeBackend(study));  // the settled soil: deposited by the first run, read after
  t0 = Clock::now();
  const double c0 = threadCpuSeconds();
  switch (placement) {
    case Placement::InProcess: cost.steps = driver.run(dem).steps; break;
    case Placement::Remote: cost.steps = runRemote(driver, dem, out); break;
  }
  cost.total = {std::chrono::duration<double>(Clock::now() - t0).count(), threadCpuSeconds() - c0};
  cost.dem = dem.inside;  // on the server's thread when remote, this thread in process
  switch (placement) {
    case Placement::InProcess: cost.fem_cpu_s = cost.total.cpu_s - cost.dem.cpu_s; break;
    case Placement::Remote: cost.fem_cpu_s = cost.total.cpu_s; break;
  }
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

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
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
    std::printf("%-8s %-10s %8s %14s %14s %14s %14s %14s\n", "FEM", "DEM", "steps", "set-up (s)", "DEM/step (ms)", "FEM/step (ms)",
                "FEM wall (%)", "FEM cpu (%)");
    for (const auto& v : variants) {
      std::vector<double> setup, dem_ms, fem_ms, wall_share, cpu_share;
      for (const RunCost& c : v.costs) {
        const auto n = static_cast<double>(c.steps);
        setup.push_back(c.reduction_s);
        dem_ms.push_back(1e3 * c.dem.wall_s / n);
        fem_ms.push_back(1e3 * (c.total.wall_s - c.dem.wall_s) / n);
        wall_share.push_back(100 * c.femWallShare());
        cpu_share.push_back(100 * c.femCpuShare());
      }
      const std::string placement = placementName(v.placement);
      std::printf("%-8s %-10s %8lld %14.2f %14.3f %14.4f %14.2f %14.2f\n", v.integration.c_str(), placement.c_str(),
                  static_cast<long long>(v.costs.front().steps), median(setup), median(dem_ms), median(fem_ms), median(wall_share),
                  median(cpu_share));
      rows.push_back({{"integration", v.integration},
                      {"dem", placement},
                      {"steps", v.costs.front().steps},
                      {"setup_s", median(setup)},
                      {"dem_per_step_ms", median(dem_ms)},
                      {"fem_per_step_ms", median(fem_ms)},
                      {"fem_wall_percent", median(wall_share)},
                      {"fem_cpu_percent", median(cpu_share)}});
    }
    cli::writeJson(json_target, {{"study", study_file}, {"rounds", rounds}, {"runs", rows}});
  });
  return cli::runApp(app, argc, argv);
}
