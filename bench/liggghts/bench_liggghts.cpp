// Backend benchmark: the built-in DEM and LIGGGHTS side by side on the same settled soil (the
// backend-neutral soil file both read, deposited once per seed by the study's deposition backend).
// - Speed (default): the study's soil and first tool with plain hooke, tangential history and cdt
//   rolling friction, the same calls on both backends: particle-steps per second on 1 and 2 cores
//   (built-in: threads; LIGGGHTS: MPI ranks via mpirun), their ratio, and the mean draught
//   force over the same drag window with its scatter over the seeds. Deposition and insertion are
//   not timed. With --rounds R every (seed, cores) pair is run R times, the backends alternated
//   (A B A B), and the built-in DEM's speed over LIGGGHTS' in the same round is reported per round
//   with its median and lowest value: the machine's drift between runs cancels in a ratio of
//   neighbours.
// - --coupled: the study as it is (contact laws included), run coupled with the FEM client
//   (fem::CoupledDriver) in-process on each backend, one core, per seed: mean draught and mean
//   load-cell force over the drag phase, their mean and scatter over the seeds and the difference
//   between the backends in standard errors; for a finished run (no --steps) also the paper's
//   evaluation of its sensors (campaign/paper_report.hpp: window means and spreads of force and
//   deformation, the power-law fit of the spectrum, the tilt range), so that a paper case
//   (--study studies/paper/..., --stroke-mm to shorten it) is compared as its report compares it.
// Prints a table; --json writes the same numbers.
//
// Every LIGGGHTS run starts this program again under `mpirun -np N` in worker mode (--worker), so that
// this process never initialises MPI: an MPI singleton's environment, inherited by a child mpirun,
// makes that mpirun fail (the 2-rank runs failed so before).
#include "bench_statistics.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/adapter/tool_drive.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/campaign/paper_report.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/study/backend_capabilities.hpp"
#include "demfem/study/study.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <unistd.h>

namespace {

using namespace demfem;
using Clock = std::chrono::steady_clock;

struct RunResult {
  std::string backend;
  int cores = 1;
  std::uint64_t seed = 1;
  int round = 1;  // speed runs: the interleaved round (--rounds)
  std::int64_t particles = 0;
  std::int64_t steps = 0;
  double wall_s = 0;
  double cpu_s = std::numeric_limits<double>::quiet_NaN();  // speed runs: CPU time of the timed window: the built-in DEM's process (all threads), LIGGGHTS' rank 0
  double draught_N = 0;  // mean force on the tool against the drag (-z), over the window
  double load_cell_N = std::numeric_limits<double>::quiet_NaN();  // coupled: mean load-cell force of the drag
  double surface_mm = std::numeric_limits<double>::quiet_NaN();  // soilSurface() of the run's soil
  // Coupled, finished runs: the paper's evaluation of the sensors (campaign::evaluatePaperRun); NaN otherwise.
  double window_begin_mm = std::numeric_limits<double>::quiet_NaN(), window_end_mm = window_begin_mm;
  double force_mean_N = window_begin_mm, force_std_dev_N = window_begin_mm;
  double deformation_mean_mm = window_begin_mm, deformation_std_dev_mm = window_begin_mm;
  double fit_a = window_begin_mm, fit_b = window_begin_mm, fit_b_std_error = window_begin_mm;
  double tilt_min_deg = window_begin_mm, tilt_max_deg = window_begin_mm;
  double particleStepsPerSecond() const { return static_cast<double>(particles) * static_cast<double>(steps) / wall_s; }
};

nlohmann::json toJson(const RunResult& r) {
  return {{"backend", r.backend},     {"cores", r.cores},        {"seed", r.seed},  {"round", r.round},
          {"particles", r.particles}, {"steps", r.steps},        {"wall_s", r.wall_s},        {"cpu_s", r.cpu_s},
          {"draught_N", r.draught_N}, {"load_cell_N", r.load_cell_N}, {"particle_steps_per_s", r.particleStepsPerSecond()},
          {"surface_mm", r.surface_mm},
          {"window_begin_mm", r.window_begin_mm}, {"window_end_mm", r.window_end_mm},
          {"force_mean_N", r.force_mean_N}, {"force_std_dev_N", r.force_std_dev_N},
          {"deformation_mean_mm", r.deformation_mean_mm}, {"deformation_std_dev_mm", r.deformation_std_dev_mm},
          {"fit_a", r.fit_a}, {"fit_b", r.fit_b}, {"fit_b_std_error", r.fit_b_std_error},
          {"tilt_min_deg", r.tilt_min_deg}, {"tilt_max_deg", r.tilt_max_deg}};
}

// A number of toJson(), NaN where it wrote null.
double numberOrNaN(const nlohmann::json& j, const char* key) {
  return j.at(key).is_null() ? std::numeric_limits<double>::quiet_NaN() : j.at(key).get<double>();
}

RunResult fromJson(const nlohmann::json& j) {
  RunResult r;
  r.backend = j.at("backend"), r.cores = j.at("cores"), r.seed = j.at("seed"), r.particles = j.at("particles");
  r.steps = j.at("steps"), r.wall_s = j.at("wall_s");
  if (!j.at("cpu_s").is_null()) r.cpu_s = j.at("cpu_s");
  // NaN (no drag interval, no coupled run) is written as null.
  r.draught_N = numberOrNaN(j, "draught_N");
  r.load_cell_N = numberOrNaN(j, "load_cell_N");
  r.surface_mm = numberOrNaN(j, "surface_mm");
  r.window_begin_mm = numberOrNaN(j, "window_begin_mm"), r.window_end_mm = numberOrNaN(j, "window_end_mm");
  r.force_mean_N = numberOrNaN(j, "force_mean_N"), r.force_std_dev_N = numberOrNaN(j, "force_std_dev_N");
  r.deformation_mean_mm = numberOrNaN(j, "deformation_mean_mm");
  r.deformation_std_dev_mm = numberOrNaN(j, "deformation_std_dev_mm");
  r.fit_a = numberOrNaN(j, "fit_a"), r.fit_b = numberOrNaN(j, "fit_b"), r.fit_b_std_error = numberOrNaN(j, "fit_b_std_error");
  r.tilt_min_deg = numberOrNaN(j, "tilt_min_deg"), r.tilt_max_deg = numberOrNaN(j, "tilt_max_deg");
  return r;
}

// The study both backends run: the file's soil and tool with the LIGGGHTS-compatible contact law.
// Insertion is not timed: a fast one keeps the benchmark short (both backends alike).
constexpr double kInsertionVelocity_m_s = 0.3;

// Settling threshold of the benchmark's soil (J); 0: the study's soil.settle_kinetic_energy_J.
double g_settle_kinetic_energy_J = 0;

// Deposition backend of every soil ("": the study's soil.deposition.backend).
std::string g_deposition;

// Coupled mode: the study as it is with the FEM client; g_fem_steps > 0 stops after that many FEM steps.
bool g_coupled = false;
std::int64_t g_fem_steps = 0;

// Coupled mode: > 0 shortens the first tool's stroke to this (mm).
double g_stroke_mm = 0;

// Length of one simulate() call (s); 0: the study's FEM step, as a coupled run calls it. A call as
// long as the window times the engines alone: LIGGGHTS then does its run set-up (`pre yes`) once
// instead of once per coupling interval.
double g_interval_s = 0;

// The study file with the benchmark's seed, cores, deposition backend and settling threshold.
study::Study seededStudy(const std::string& file, std::uint64_t seed, int cores) {
  study::Study s = study::loadStudy(file);
  if (g_settle_kinetic_energy_J > 0) s.soil.settle_kinetic_energy_J = g_settle_kinetic_energy_J;
  if (!g_deposition.empty()) s.soil.deposition_backend = g_deposition;
  s.soil.deposition_seed = seed;
  s.dem.threads = cores;
  if (s.tools.empty()) throw cli::InputError(file + ": the benchmark drags the study's first tool; it has none");
  if (g_stroke_mm > 0) s.tools.front().motion.stroke_m = g_stroke_mm * 1e-3;
  return s;
}

double surface_mm(const study::Study& s) {
  const auto file = adapter::settledSoilFile(s, adapter::defaultSoilDirectory());
  return 1e3 * adapter::readSettledSoil(file, s).settling.surface_height_m;
}

study::Study benchStudy(const std::string& file, std::uint64_t seed, int cores) {
  study::Study s = seededStudy(file, seed, cores);
  s.soil.contact.normal = study::NormalModel::Hooke;
  s.soil.contact.tangential_history = true;
  s.soil.contact.cohesion = study::CohesionModel::None;
  s.soil.contact.rolling = study::RollingModel::Cdt;
  s.tools.front().motion.insertion_velocity_m_s = kInsertionVelocity_m_s;
  return s;
}

// Insertion (untimed), then the drag window in simulate() calls of g_interval_s (default: FEM-step
// sized, as a coupled run does).
RunResult drag(adapter::CouplingApi& dem, const study::Study& s, double window_s, std::int64_t particles) {
  const auto& tool = s.tools.front();
  adapter::insertAndStartDrag(dem, s, tool);
  const double interval = g_interval_s > 0 ? g_interval_s : (s.fem.dt_s > 0 ? s.fem.dt_s : 1e-3);
  const auto intervals = std::max<long>(1, std::lround(window_s / interval));
  const double t0 = dem.time();
  RunResult r;
  r.particles = particles;
  const auto start = Clock::now();
  const std::clock_t cpu_start = std::clock();
  for (long i = 0; i < intervals; ++i) {
    dem.simulate(interval);
    adapter::accumulateDraught(r.draught_N, dem.nodeForces(tool.name, adapter::ForceMode::IntervalMean));
  }
  r.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  r.cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  r.draught_N /= static_cast<double>(intervals);
  r.steps = std::llround((dem.time() - t0) / dem.info().dem_time_step_s);
  return r;
}

// Forwards every call to the backend; after each simulate() of the drag phase (the tool's rigid
// motion along +z only) adds the tool's draught, -sum f_z of the interval-mean node forces.
class DraughtTap final : public adapter::CouplingApi {
 public:
  DraughtTap(adapter::CouplingApi& dem, std::string tool) : dem_(dem), tool_(std::move(tool)) {}
  adapter::BackendInfo info() override { return dem_.info(); }
  std::vector<adapter::GeometryInfo> geometries() override { return dem_.geometries(); }
  double time() override { return dem_.time(); }
  adapter::NodeArray nodePositions(const std::string& g) override { return dem_.nodePositions(g); }
  adapter::NodeArray nodeForces(const std::string& g, adapter::ForceMode mode) override { return dem_.nodeForces(g, mode); }
  void setNodePositions(const std::string& g, const adapter::NodeArray& xyz) override { dem_.setNodePositions(g, xyz); }
  void simulate(double duration_s) override {
    dem_.simulate(duration_s);
    if (!dragging_) return;
    adapter::accumulateDraught(sum_N_, dem_.nodeForces(tool_, adapter::ForceMode::IntervalMean));
    ++intervals_;
  }
  adapter::RigidMotion rigidMotion(const std::string& g) override { return dem_.rigidMotion(g); }
  void setRigidMotion(const std::string& g, const adapter::RigidMotion& m) override {
    dem_.setRigidMotion(g, m);
    if (g == tool_) dragging_ = m.velocity_m_s[2] > 0 && m.velocity_m_s[0] == 0 && m.velocity_m_s[1] == 0;
  }
  void checkpoint(const std::filesystem::path& file) override { dem_.checkpoint(file); }
  void restore(const std::filesystem::path& file) override { dem_.restore(file); }
  void shutdown() override { dem_.shutdown(); }
  double meanDraught_N() const { return intervals_ ? sum_N_ / static_cast<double>(intervals_) : std::nan(""); }

 private:
  adapter::CouplingApi& dem_;
  std::string tool_;
  bool dragging_ = false;
  double sum_N_ = 0;
  long intervals_ = 0;
};

// The paper's evaluation of a finished coupled run's sensors into `r`.
void evaluateAsPaperCase(const analysis::Recording& sensors, const study::Study& s, RunResult& r) {
  const campaign::RunEvaluation e = campaign::evaluatePaperRun(sensors, s);
  r.window_begin_mm = e.window_begin_mm, r.window_end_mm = e.window_end_mm;
  r.force_mean_N = e.window.force_N.mean, r.force_std_dev_N = e.window.force_N.std_dev;
  r.deformation_mean_mm = e.window.deformation_mm.mean, r.deformation_std_dev_mm = e.window.deformation_mm.std_dev;
  r.fit_a = e.fit.a, r.fit_b = e.fit.b, r.fit_b_std_error = e.fit.b_std_error;
  if (e.tilt_range_deg) r.tilt_min_deg = e.tilt_range_deg->first, r.tilt_max_deg = e.tilt_range_deg->second;
}

// The study as it is, coupled with the FEM client in this process (FEM model built first, untimed):
// mean draught and mean load-cell force over the drag phase (or the first g_fem_steps FEM steps).
RunResult coupledRun(const study::Study& s, const std::function<std::unique_ptr<adapter::CouplingApi>()>& make,
                     const std::function<std::int64_t(adapter::CouplingApi&)>& particles) {
  fem::CoupledRunOptions options;
  options.output_dir = std::filesystem::temp_directory_path() /
                       ("demfem-bench-coupled-" + std::to_string(::getpid()) + "-" + std::to_string(s.soil.deposition_seed));
  if (g_fem_steps > 0) options.max_steps = g_fem_steps;
  fem::CoupledDriver driver(s, options);
  auto dem = make();
  DraughtTap tap(*dem, s.tools.front().name);
  const double dt = dem->info().dem_time_step_s;
  RunResult r;
  r.particles = particles(*dem);
  const double t0 = dem->time();
  const auto summary = driver.run(tap);
  r.wall_s = summary.wall_time_s;
  r.steps = std::llround((dem->time() - t0) / dt);
  r.draught_N = tap.meanDraught_N();
  r.load_cell_N = summary.mean_force_N;
  r.surface_mm = surface_mm(s);
  if (g_fem_steps == 0) evaluateAsPaperCase(analysis::readRecording(options.output_dir / "sensors.csv"), s, r);
  std::error_code ignored;
  std::filesystem::remove_all(options.output_dir, ignored);
  return r;
}

RunResult runBuiltin(const std::string& file, std::uint64_t seed, int cores, double window_s) {
  if (g_coupled) {
    const auto s = seededStudy(file, seed, cores);
    RunResult r = coupledRun(s, [&s] { return builtin::makeBackend(s); }, [](adapter::CouplingApi& dem) {
      return nlohmann::json::parse(dem.info().soil_json).at("particles").get<std::int64_t>();
    });
    r.backend = "builtin", r.cores = cores, r.seed = seed;
    return r;
  }
  const auto s = benchStudy(file, seed, cores);
  auto dem = builtin::makeBackend(s);
  const auto particles = nlohmann::json::parse(dem->info().soil_json).at("particles").get<std::int64_t>();
  RunResult r = drag(*dem, s, window_s, particles);
  r.surface_mm = surface_mm(s);
  r.backend = "builtin", r.cores = cores, r.seed = seed;
  return r;
}

// Rank 0 of a LIGGGHTS run (the worker under mpirun); followers return {}.
std::optional<RunResult> runLiggghts(const std::string& file, std::uint64_t seed, double window_s) {
  const auto s = g_coupled ? seededStudy(file, seed, 1) : benchStudy(file, seed, 1);
  if (!liggghts::isLeaderRank()) {
    liggghts::followLeader(s);
    return std::nullopt;
  }
  int ranks = 1;
  if (const char* size = std::getenv("OMPI_COMM_WORLD_SIZE")) ranks = std::atoi(size);
  if (g_coupled) {
    RunResult r = coupledRun(s, [&s] { return liggghts::makeBackend(s); },
                             [](adapter::CouplingApi& dem) { return liggghts::particleCount(dem); });
    r.backend = "liggghts", r.cores = ranks, r.seed = seed;
    return r;
  }
  auto dem = liggghts::makeBackend(s);
  RunResult r = drag(*dem, s, window_s, liggghts::particleCount(*dem));
  r.surface_mm = surface_mm(s);
  r.backend = "liggghts", r.cores = ranks, r.seed = seed;
  dem->shutdown();
  return r;
}

// A command-line number that reads back to the same double.
std::string number(double v) {
  char text[64];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

RunResult runLiggghtsRanks(const std::string& file, std::uint64_t seed, int ranks, double window_s) {
  const auto self = std::filesystem::read_symlink("/proc/self/exe");
  const auto result = std::filesystem::temp_directory_path() /
                      ("demfem-bench-liggghts-" + std::to_string(::getpid()) + "-" + std::to_string(seed) + ".json");
  // --oversubscribe: the ranks may outnumber the cores mpirun counts; running as root (containers)
  // needs OpenMPI's explicit consent.
  const std::string command = std::string("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 ") +
                              DEMFEM_MPIEXEC + " -np " + std::to_string(ranks) + " --oversubscribe '" + self.string() +
                              "' --study '" + file + "' --worker " + std::to_string(seed) + " --window-s " + number(window_s) +
                              " --settle-kinetic-energy-J " + number(g_settle_kinetic_energy_J) + " --interval-s " + number(g_interval_s) +
                              (g_deposition.empty() ? "" : " --deposition " + g_deposition) +
                              (g_coupled ? " --coupled --steps " + std::to_string(g_fem_steps) : "") +
                              (g_stroke_mm > 0 ? " --stroke-mm " + number(g_stroke_mm) : "") +
                              " --json '" + result.string() + "'";
  if (std::system(command.c_str()) != 0) throw std::runtime_error("the LIGGGHTS run under mpirun failed: " + command);
  std::ifstream in(result);
  const auto j = nlohmann::json::parse(in);
  std::filesystem::remove(result);
  return fromJson(j);
}

// The paper's evaluation of each finished coupled run, one row per run.
void printPaperEvaluation(const std::vector<RunResult>& runs) {
  std::printf("%-9s %5s %13s %19s %23s %17s %17s\n", "backend", "seed", "window_mm", "force_N mean+-sd",
              "deformation_mm mean+-sd", "fit b +- se", "tilt_deg min..max");
  for (const auto& r : runs)
    std::printf("%-9s %5llu %6.0f-%-6.0f %9.4g +- %-7.3g %11.4g +- %-9.3g %7.3f +- %-6.3f %7.2f..%-7.2f\n", r.backend.c_str(),
                static_cast<unsigned long long>(r.seed), r.window_begin_mm, r.window_end_mm, r.force_mean_N, r.force_std_dev_N,
                r.deformation_mean_mm, r.deformation_std_dev_mm, r.fit_b, r.fit_b_std_error, r.tilt_min_deg, r.tilt_max_deg);
}

// Both backends must implement the laws the runs use (the study's in coupled mode): said before the
// first run, which may take many minutes, not when the LIGGGHTS run starts after it.
void requireBothBackends(const std::string& file, study::Study s) {
  std::string problems;
  for (const char* backend : {"builtin", "liggghts"}) {
    s.dem.backend = backend;
    for (const study::Issue& i : study::backendIssues(s, {builtin::capabilities(), liggghts::capabilities()}))
      problems += "\n  " + file + ": " + i.path + ": " + i.message;
  }
  if (!problems.empty()) throw cli::InputError("the benchmark runs the study on both backends, which it does not fit:" + problems);
}

// Per (seed, round) with both backends on `cores`: the built-in DEM's particle-steps per second
// over LIGGGHTS', in run order.
std::vector<double> builtinOverLiggghtsPerRound(const std::vector<RunResult>& runs, int cores) {
  std::vector<double> ratios;
  for (const auto& b : runs) {
    if (b.backend != "builtin" || b.cores != cores) continue;
    for (const auto& l : runs)
      if (l.backend == "liggghts" && l.cores == cores && l.seed == b.seed && l.round == b.round)
        ratios.push_back(b.particleStepsPerSecond() / l.particleStepsPerSecond());
  }
  return ratios;
}

struct Summary {
  double mean = 0, stddev = 0;
};

Summary summarise(const std::vector<double>& values) {
  Summary s;
  for (double v : values) s.mean += v / static_cast<double>(values.size());
  if (values.size() > 1) {
    for (double v : values) s.stddev += (v - s.mean) * (v - s.mean);
    s.stddev = std::sqrt(s.stddev / static_cast<double>(values.size() - 1));
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-liggghts: LIGGGHTS against the built-in DEM on one study, 1 and 2 cores"};
  app.name("demfem-bench-liggghts");
  // The quick bin with the soil stiffness of the paper's EDEM spring (quick_liggghts.json notes);
  // quick.json's E would make LIGGGHTS' hooke spring 100x stiffer and the step 10x shorter.
  std::string file = std::string(DEMFEM_SOURCE_DIR) + "/studies/quick_liggghts.json";
  int seeds = 3, rounds = 1;
  std::vector<int> core_counts{1, 2};
  double window_s = 1.0;
  std::uint64_t worker_seed = 0;
  app.add_option("--study", file, "Study whose soil and first tool are used (speed runs replace its contact law, --coupled runs keep it)")
      ->check(CLI::ExistingFile);
  app.add_option("--seeds", seeds, "Deposition seeds 1..N for the draught-force scatter")->check(CLI::PositiveNumber);
  app.add_option("--rounds", rounds, "Speed runs: interleaved rounds per seed and core count (the backends alternated)")
      ->check(CLI::PositiveNumber);
  app.add_option("--cores", core_counts, "Speed runs: core counts to time (default 1 2)")->check(CLI::Range(1, 64));
  app.add_option("--window-s", window_s, "Simulated drag time that is timed and averaged (s)")
      ->check(CLI::PositiveNumber);
  app.add_option("--settle-kinetic-energy-J", g_settle_kinetic_energy_J,
                 "Deposition ends below this kinetic energy (J), both backends (LIGGGHTS: translational only); "
                 "default: the study's")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--interval-s", g_interval_s,
                 "Simulated time per simulate() call (s); default: the study's FEM step. Equal to --window-s: "
                 "one call, the engines' own speed without per-call set-up")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--deposition", g_deposition,
                 "Backend that deposits every soil both backends start from: builtin | liggghts (default: the study's "
                 "soil.deposition.backend)")
      ->check(CLI::IsMember({"builtin", "liggghts"}));
  app.add_flag("--coupled", g_coupled,
               "Run the study as it is, coupled with the FEM client, on one core per backend: mean draught and "
               "load-cell force over the drag phase");
  app.add_option("--steps", g_fem_steps, "--coupled: stop after this many FEM steps (insertion included; default: "
                                         "the whole study)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--stroke-mm", g_stroke_mm, "--coupled: shorten the first tool's stroke to this (mm); the paper's "
                                             "window scales with it (campaign/paper_report.hpp)")
      ->check(CLI::PositiveNumber);
  app.add_option("--worker", worker_seed, "Internal: run LIGGGHTS with this seed as an MPI job and write --json");
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    if (worker_seed > 0) {
      if (const auto r = runLiggghts(file, worker_seed, window_s)) cli::writeJson(json_target, toJson(*r));
      return;
    }
    requireBothBackends(file, g_coupled ? seededStudy(file, 1, 1) : benchStudy(file, 1, 1));
    const bool text = json_target != "-";
    if (text)
      std::printf("%-9s %5s %5s %9s %10s %8s %9s %9s %14s %11s %11s\n", "backend", "cores", "seed", "particles",
                  "surface_mm", "steps", "wall_s", "cpu_s", "particle-st/s", "draught_N", "load_cell_N");
    std::vector<RunResult> runs;
    auto record = [&runs, text](const RunResult& r) {  // one row as soon as a run ends: runs are long
      runs.push_back(r);
      if (!text) return;
      std::printf("%-9s %5d %5llu %9lld %10.2f %8lld %9.2f %9.2f %14.3e %11.4f %11.4f\n", r.backend.c_str(), r.cores,
                  static_cast<unsigned long long>(r.seed), static_cast<long long>(r.particles), r.surface_mm,
                  static_cast<long long>(r.steps), r.wall_s, r.cpu_s, r.particleStepsPerSecond(), r.draught_N, r.load_cell_N);
      std::fflush(stdout);
    };
    // The soil's own backend runs first on each seed: its construction deposits the soil file.
    const bool liggghts_first = seededStudy(file, 1, 1).soil.deposition_backend == "liggghts";
    if (g_coupled) core_counts = {1}, rounds = 1;
    for (int seed = 1; seed <= seeds; ++seed)
      for (int cores : core_counts)
        for (int round = 1; round <= rounds; ++round) {
          const auto seed_u = static_cast<std::uint64_t>(seed);
          const auto inRound = [round](RunResult r) {
            r.round = round;
            return r;
          };
          if (liggghts_first) record(inRound(runLiggghtsRanks(file, seed_u, cores, window_s)));
          record(inRound(runBuiltin(file, seed_u, cores, window_s)));
          if (!liggghts_first) record(inRound(runLiggghtsRanks(file, seed_u, cores, window_s)));
        }

    if (text && g_coupled) printPaperEvaluation(runs);
    // Per backend and core count: speed, draught and load cell, mean and sample standard deviation
    // over seeds; per core count the difference of the backends against its standard error.
    nlohmann::json summary = nlohmann::json::object();
    for (int cores : core_counts) {
      std::map<std::string, Summary> speed, draught, load_cell, window_force, window_deformation;
      std::vector<double> draught_diff, load_diff;  // per seed, liggghts - builtin (same soil)
      for (const std::string backend : {"builtin", "liggghts"}) {
        std::vector<double> d, rate, lc, wf, wd;
        for (const auto& r : runs) {
          if (r.backend != backend || r.cores != cores) continue;
          rate.push_back(r.particleStepsPerSecond());
          if (r.round != 1) continue;  // a seed's forces once: its rounds repeat them
          d.push_back(r.draught_N);
          lc.push_back(r.load_cell_N);
          wf.push_back(r.force_mean_N);
          wd.push_back(r.deformation_mean_mm);
        }
        speed[backend] = summarise(rate), draught[backend] = summarise(d), load_cell[backend] = summarise(lc);
        window_force[backend] = summarise(wf), window_deformation[backend] = summarise(wd);
        if (text)
          std::printf("%-9s %d core(s), %d seeds: %.3e +- %.1e particle-steps/s, draught %.4f +- %.4f N, load cell "
                      "%.4f +- %.4f N\n",
                      backend.c_str(), cores, seeds, speed[backend].mean, speed[backend].stddev, draught[backend].mean,
                      draught[backend].stddev, load_cell[backend].mean, load_cell[backend].stddev);
        summary[backend + "_" + std::to_string(cores) + "_cores"] = {
            {"particle_steps_per_s_mean", speed[backend].mean}, {"particle_steps_per_s_stddev", speed[backend].stddev},
            {"draught_mean_N", draught[backend].mean},          {"draught_stddev_N", draught[backend].stddev},
            {"load_cell_mean_N", load_cell[backend].mean},      {"load_cell_stddev_N", load_cell[backend].stddev}};
      }
      const auto compare = [&](const char* name, std::map<std::string, Summary>& m, const char* unit = "N") {
        const double diff = m["liggghts"].mean - m["builtin"].mean;
        const double n = static_cast<double>(seeds);
        const double se = std::sqrt((m["liggghts"].stddev * m["liggghts"].stddev + m["builtin"].stddev * m["builtin"].stddev) / n);
        const double relative = diff / (0.5 * (m["liggghts"].mean + m["builtin"].mean));
        // One seed has no seed scatter: the difference is not set against one (null in the JSON).
        const nlohmann::json in_errors = seeds > 1 ? nlohmann::json(diff / se) : nlohmann::json(nullptr);
        char against[96] = "one seed: no seed scatter to compare with";
        if (seeds > 1) std::snprintf(against, sizeof against, "%.2f standard errors of the difference (seed scatter)", diff / se);
        if (text)
          std::printf("%s, %d core(s): liggghts - builtin = %.4g %s (%.1f %% of their mean), %s\n", name, cores, diff, unit,
                      100 * relative, against);
        return nlohmann::json{{std::string("difference_") + unit, diff}, {"relative_difference", relative},
                              {std::string("standard_error_") + unit, se}, {"difference_in_standard_errors", in_errors}};
      };
      nlohmann::json c{{"draught", compare("draught", draught)}};
      if (g_coupled) c["load_cell"] = compare("load cell", load_cell);
      if (g_coupled && g_fem_steps == 0) {
        c["window_force"] = compare("window-mean load cell", window_force);
        c["window_deformation"] = compare("window-mean deformation", window_deformation, "mm");
      }
      summary["liggghts_minus_builtin_" + std::to_string(cores) + "_cores"] = c;
      const double ratio = speed["liggghts"].mean / speed["builtin"].mean;
      if (text) std::printf("speed ratio liggghts / builtin on %d core(s): %.3f\n", cores, ratio);
      summary["speed_ratio_liggghts_over_builtin_" + std::to_string(cores) + "_cores"] = ratio;
      const std::vector<double> per_round = builtinOverLiggghtsPerRound(runs, cores);
      if (!per_round.empty()) {
        const double median = bench::median(per_round);
        const double lowest = *std::min_element(per_round.begin(), per_round.end());
        if (text) {
          std::printf("built-in / liggghts speed on %d core(s), per round (same seed, runs side by side):", cores);
          for (double r : per_round) std::printf(" %.2fx", r);
          std::printf("; median %.2fx, lowest %.2fx\n", median, lowest);
        }
        summary["speed_ratio_builtin_over_liggghts_per_round_" + std::to_string(cores) + "_cores"] = {
            {"per_round", per_round}, {"median", median}, {"lowest", lowest}};
      }
    }
    nlohmann::json all = nlohmann::json::array();
    for (const auto& r : runs) all.push_back(toJson(r));
    const auto s1 = seededStudy(file, 1, 1);
    cli::writeJson(json_target, {{"study", file},
                                 {"coupled", g_coupled},
                                 {"fem_steps", g_fem_steps},
                                 {"window_s", window_s},
                                 {"interval_s", g_interval_s},
                                 {"settle_kinetic_energy_J", s1.soil.settle_kinetic_energy_J},
                                 {"deposition_backend", s1.soil.deposition_backend},
                                 {"runs", all},
                                 {"summary", summary}});
  });
  return cli::runApp(app, argc, argv);
}
