// Share of the FEM client in a coupled run (fem/coupled_driver.hpp) on a study's bin with the built-in
// DEM in-process: the time spent inside the DEM's coupling calls against the rest (FEM step,
// sensors, outputs), for the full and the modal integration (study fem.integration; --integrations
// picks them), in interleaved rounds (full, modal, full, modal, ...) on the same settled soil. Wall and processor time of the
// calling thread; the DEM runs on the study's dem.threads. Prints a table; --json writes the same.
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
#include <sstream>
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

class TimedDem : public adapter::CouplingApi {
  // Adds the wall and thread processor time of its lifetime to `inside`.
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
  explicit TimedDem(std::unique_ptr<adapter::CouplingApi> inner) : inner_(std::move(inner)) {}
  Clocks inside;

  adapter::BackendInfo info() override { Scope s(inside); return inner_->info(); }
  std::vector<adapter::GeometryInfo> geometries() override { Scope s(inside); return inner_->geometries(); }
  double time() override { Scope s(inside); return inner_->time(); }
  adapter::NodeArray nodePositions(const std::string& g) override { Scope s(inside); return inner_->nodePositions(g); }
  adapter::NodeArray nodeForces(const std::string& g, adapter::ForceMode m) override { Scope s(inside); return inner_->nodeForces(g, m); }
  void setNodePositions(const std::string& g, const adapter::NodeArray& x) override { Scope s(inside); inner_->setNodePositions(g, x); }
  void simulate(double d) override { Scope s(inside); inner_->simulate(d); }
  adapter::RigidMotion rigidMotion(const std::string& g) override { Scope s(inside); return inner_->rigidMotion(g); }
  void setRigidMotion(const std::string& g, const adapter::RigidMotion& m) override { Scope s(inside); inner_->setRigidMotion(g, m); }
  void checkpoint(const fs::path& f) override { Scope s(inside); inner_->checkpoint(f); }
  void restore(const fs::path& f) override { Scope s(inside); inner_->restore(f); }
  void shutdown() override { inner_->shutdown(); }

 private:
  std::unique_ptr<adapter::CouplingApi> inner_;
};

struct RunCost {
  std::int64_t steps = 0;
  double reduction_s = 0;           // the driver's construction (Eq 11-15 and the integrator set-up)
  Clocks total, dem;
  double femWallShare() const { return (total.wall_s - dem.wall_s) / total.wall_s; }
  double femCpuShare() const { return (total.cpu_s - dem.cpu_s) / total.cpu_s; }
};

RunCost coupledRun(const study::Study& study, const fs::path& out, std::optional<std::int64_t> steps) {
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
  cost.steps = driver.run(dem).steps;
  cost.total = {std::chrono::duration<double>(Clock::now() - t0).count(), threadCpuSeconds() - c0};
  cost.dem = dem.inside;
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
  CLI::App app{"demfem-bench-coupled: share of the FEM client in a coupled run on the built-in DEM, full against modal integration"};
  app.name("demfem-bench-coupled");
  std::string study_file = std::string(DEMFEM_SOURCE_DIR) + "/studies/quick.json";
  int rounds = 1;
  std::int64_t steps = 0;
  app.add_option("--study", study_file, "coupled study")->check(CLI::ExistingFile)->capture_default_str();
  app.add_option("--rounds", rounds, "interleaved rounds (one run of each --integrations value)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--steps", steps, "FEM steps per run (0: the whole plan)")->check(CLI::NonNegativeNumber);
  std::vector<std::string> kinds{"full", "modal"};
  app.add_option("--integrations", kinds, "study fem.integration values timed in each round, in this order")
      ->check(CLI::IsMember({"full", "modal"}))
      ->capture_default_str();
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    const fs::path scratch = fs::temp_directory_path() / ("demfem-bench-coupled-" + std::to_string(getpid()));
    const std::optional<std::int64_t> max_steps = steps > 0 ? std::optional<std::int64_t>(steps) : std::nullopt;
    std::vector<std::vector<RunCost>> costs(kinds.size());
    for (int r = 0; r < rounds; ++r)
      for (std::size_t k = 0; k < kinds.size(); ++k) {
        std::fprintf(stderr, "round %d of %d: %s integration\n", r + 1, rounds, kinds[k].c_str());
        costs[k].push_back(coupledRun(withIntegration(study_file, kinds[k]), scratch / kinds[k], max_steps));
      }
    fs::remove_all(scratch);
    nlohmann::json rows = nlohmann::json::array();
    std::printf("%-8s %8s %14s %14s %14s %14s %14s\n", "FEM", "steps", "set-up (s)", "DEM/step (ms)", "FEM/step (ms)", "FEM wall (%)",
                "FEM cpu (%)");
    for (std::size_t k = 0; k < kinds.size(); ++k) {
      std::vector<double> setup, dem_ms, fem_ms, wall_share, cpu_share;
      for (const RunCost& c : costs[k]) {
        const auto n = static_cast<double>(c.steps);
        setup.push_back(c.reduction_s);
        dem_ms.push_back(1e3 * c.dem.wall_s / n);
        fem_ms.push_back(1e3 * (c.total.wall_s - c.dem.wall_s) / n);
        wall_share.push_back(100 * c.femWallShare());
        cpu_share.push_back(100 * c.femCpuShare());
      }
      const auto& name = kinds[k];
      std::printf("%-8s %8lld %14.2f %14.3f %14.4f %14.2f %14.2f\n", name.c_str(), static_cast<long long>(costs[k].front().steps),
                  median(setup), median(dem_ms), median(fem_ms), median(wall_share), median(cpu_share));
      rows.push_back({{"integration", name},
                      {"steps", costs[k].front().steps},
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
