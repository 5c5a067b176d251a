// Backend benchmark: the same study, contact law (plain hooke, tangential history, cdt rolling
// friction) and calls on the built-in DEM and on LIGGGHTS, side by side: particle-steps per second on
// 1 and 2 cores (built-in: OpenMP threads; LIGGGHTS: MPI ranks via mpirun), their ratio, and the mean
// draught force over the same drag window with its scatter over the seeds. Deposition and insertion
// are not timed. Prints a table; --json writes the same numbers.
//
// Every LIGGGHTS run starts this program again under `mpirun -np N` in worker mode (--worker), so that
// this process never initialises MPI: an MPI singleton's environment, inherited by a child mpirun,
// makes that mpirun fail (the 2-rank runs failed so before).
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/adapter/tool_drive.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/study/study.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <unistd.h>

namespace {

using namespace demfem;
using Clock = std::chrono::steady_clock;

struct RunResult {
  std::string backend;
  int cores = 1;
  std::uint64_t seed = 1;
  std::int64_t particles = 0;
  std::int64_t steps = 0;
  double wall_s = 0;
  double draught_N = 0;  // mean force on the tool against the drag (-z), over the window
  double surface_mm = std::numeric_limits<double>::quiet_NaN();  // soilSurface() of the run's soil
  double particleStepsPerSecond() const { return static_cast<double>(particles) * static_cast<double>(steps) / wall_s; }
};

nlohmann::json toJson(const RunResult& r) {
  return {{"backend", r.backend}, {"cores", r.cores},      {"seed", r.seed},
          {"particles", r.particles}, {"steps", r.steps}, {"wall_s", r.wall_s},
          {"draught_N", r.draught_N}, {"particle_steps_per_s", r.particleStepsPerSecond()},
          {"surface_mm", r.surface_mm}};
}

// Height of the settled soil's surface (mm above the floor): the mean top (y + r) of the particles
// whose top lies within one largest diameter of the highest top. The tool's depth is measured from
// the study's fill height, so a surface above it means a deeper cut.
double soilSurface_mm(const std::vector<std::array<double, 2>>& y_and_radius, double diameter_max_m) {
  double highest = 0;
  for (const auto& p : y_and_radius) highest = std::max(highest, p[0] + p[1]);
  double sum = 0;
  int count = 0;
  for (const auto& p : y_and_radius)
    if (p[0] + p[1] > highest - diameter_max_m) sum += p[0] + p[1], ++count;
  return 1e3 * sum / count;
}

// The study both backends run: the file's soil and tool with the LIGGGHTS-compatible contact law.
// Insertion is not timed: a fast one keeps the benchmark short (both backends alike).
constexpr double kInsertionVelocity_m_s = 0.3;

// Settling threshold of the benchmark's soil (J); 0: the study's soil.settle_kinetic_energy_J.
double g_settle_kinetic_energy_J = 0;

// LIGGGHTS drags through the built-in backend's settled soil of the same seed (1 thread) instead of
// its own: the two contact implementations on the same particles.
bool g_liggghts_on_builtin_soil = false;

// Length of one simulate() call (s); 0: the study's FEM step, as a coupled run calls it. A call as
// long as the window times the engines alone: LIGGGHTS then does its run set-up (`pre yes`) once
// instead of once per coupling interval.
double g_interval_s = 0;

study::Study benchStudy(const std::string& file, std::uint64_t seed, int cores) {
  study::Study s = study::loadStudy(file);
  if (g_settle_kinetic_energy_J > 0) s.soil.settle_kinetic_energy_J = g_settle_kinetic_energy_J;
  s.soil.contact.normal = study::NormalModel::Hooke;
  s.soil.contact.tangential_history = true;
  s.soil.contact.cohesion = study::CohesionModel::None;
  s.soil.contact.rolling = study::RollingModel::Cdt;
  s.soil.deposition_seed = seed;
  s.dem.threads = cores;
  if (s.tools.empty()) throw cli::InputError(file + ": the benchmark drags the study's first tool; it has none");
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
  for (long i = 0; i < intervals; ++i) {
    dem.simulate(interval);
    const auto f = dem.nodeForces(tool.name, adapter::ForceMode::IntervalMean);
    for (std::size_t k = 2; k < f.size(); k += 3) r.draught_N -= f[k];
  }
  r.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  r.draught_N /= static_cast<double>(intervals);
  r.steps = std::llround((dem.time() - t0) / dem.info().dem_time_step_s);
  return r;
}

RunResult runBuiltin(const std::string& file, std::uint64_t seed, int cores, double window_s) {
  const auto s = benchStudy(file, seed, cores);
  auto dem = builtin::makeBackend(s);
  const auto soil_file = builtin::soilFile(s, builtin::defaultSoilDirectory());
  const auto settled = builtin::readSettledSoil(soil_file).particles;
  std::vector<std::array<double, 2>> y_and_radius;
  for (const auto& p : settled) y_and_radius.push_back({p.x[1], p.radius});
  RunResult r = drag(*dem, s, window_s, static_cast<std::int64_t>(settled.size()));
  r.surface_mm = soilSurface_mm(y_and_radius, s.soil.diameter_max_m);
  r.backend = "builtin", r.cores = cores, r.seed = seed;
  return r;
}

// Rank 0 of a LIGGGHTS run (the worker under mpirun); followers return {}.
std::optional<RunResult> runLiggghts(const std::string& file, std::uint64_t seed, double window_s) {
  const auto s = benchStudy(file, seed, 1);
  liggghts::BackendOptions options;  // every rank builds the same simulation, so the same options
  if (g_liggghts_on_builtin_soil)
    for (const auto& p : builtin::readSettledSoil(builtin::soilFile(s, builtin::defaultSoilDirectory())).particles)
      options.settled_soil.push_back({p.x, p.radius, s.soil.layers[static_cast<std::size_t>(p.layer)].material});
  if (!liggghts::isLeaderRank()) {
    liggghts::followLeader(s, options);
    return std::nullopt;
  }
  auto dem = liggghts::makeBackend(s, options);
  int ranks = 1;
  if (const char* size = std::getenv("OMPI_COMM_WORLD_SIZE")) ranks = std::atoi(size);
  std::vector<std::array<double, 2>> y_and_radius;
  if (ranks == 1)  // particle positions are offered on one rank; 2-rank runs read the same soil file
    for (const auto& p : liggghts::particles(*dem)) y_and_radius.push_back({p[1], p[3]});
  RunResult r = drag(*dem, s, window_s, liggghts::particleCount(*dem));
  if (ranks == 1) r.surface_mm = soilSurface_mm(y_and_radius, s.soil.diameter_max_m);
  r.backend = "liggghts", r.cores = ranks, r.seed = seed;
  dem->shutdown();
  return r;
}

RunResult runLiggghtsRanks(const std::string& file, std::uint64_t seed, int ranks, double window_s) {
  const auto self = std::filesystem::read_symlink("/proc/self/exe");
  const auto result = std::filesystem::temp_directory_path() /
                      ("demfem-bench-liggghts-" + std::to_string(::getpid()) + "-" + std::to_string(seed) + ".json");
  char window[64];
  std::snprintf(window, sizeof window, "%.17g", window_s);
  char settle[64];
  std::snprintf(settle, sizeof settle, "%.17g", g_settle_kinetic_energy_J);
  char interval[64];
  std::snprintf(interval, sizeof interval, "%.17g", g_interval_s);
  // --oversubscribe: the ranks may outnumber the cores mpirun counts; running as root (containers)
  // needs OpenMPI's explicit consent.
  const std::string command = std::string("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 ") +
                              DEMFEM_MPIEXEC + " -np " + std::to_string(ranks) + " --oversubscribe '" + self.string() +
                              "' --study '" + file + "' --worker " + std::to_string(seed) + " --window-s " + window +
                              " --settle-kinetic-energy-J " + settle + " --interval-s " + interval +
                              (g_liggghts_on_builtin_soil ? " --liggghts-on-builtin-soil" : "") +
                              " --json '" + result.string() + "'";
  if (std::system(command.c_str()) != 0) throw std::runtime_error("the LIGGGHTS run under mpirun failed: " + command);
  std::ifstream in(result);
  const auto j = nlohmann::json::parse(in);
  std::filesystem::remove(result);
  RunResult r;
  r.backend = j.at("backend"), r.cores = j.at("cores"), r.seed = j.at("seed"), r.particles = j.at("particles");
  r.steps = j.at("steps"), r.wall_s = j.at("wall_s"), r.draught_N = j.at("draught_N");
  if (!j.at("surface_mm").is_null()) r.surface_mm = j.at("surface_mm");
  return r;
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
  int seeds = 3;
  double window_s = 1.0;
  std::uint64_t worker_seed = 0;
  app.add_option("--study", file, "Study whose soil and first tool are used (contact law replaced)")
      ->check(CLI::ExistingFile);
  app.add_option("--seeds", seeds, "Deposition seeds 1..N for the draught-force scatter")->check(CLI::PositiveNumber);
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
  app.add_flag("--liggghts-on-builtin-soil", g_liggghts_on_builtin_soil,
               "LIGGGHTS starts from the built-in backend's settled soil of the same seed (same particles)");
  app.add_option("--worker", worker_seed, "Internal: run LIGGGHTS with this seed as an MPI job and write --json");
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    if (worker_seed > 0) {
      if (const auto r = runLiggghts(file, worker_seed, window_s)) cli::writeJson(json_target, toJson(*r));
      return;
    }
    std::printf("%-9s %5s %5s %9s %10s %8s %9s %14s %11s\n", "backend", "cores", "seed", "particles", "surface_mm",
                "steps", "wall_s", "particle-st/s", "draught_N");
    std::vector<RunResult> runs;
    auto record = [&runs](const RunResult& r) {  // one row as soon as a run ends: runs are long
      runs.push_back(r);
      std::printf("%-9s %5d %5llu %9lld %10.2f %8lld %9.2f %14.3e %11.4f\n", r.backend.c_str(), r.cores,
                  static_cast<unsigned long long>(r.seed), static_cast<long long>(r.particles), r.surface_mm,
                  static_cast<long long>(r.steps), r.wall_s, r.particleStepsPerSecond(), r.draught_N);
      std::fflush(stdout);
    };
    for (int seed = 1; seed <= seeds; ++seed)
      for (int cores : {1, 2}) {
        record(runBuiltin(file, static_cast<std::uint64_t>(seed), cores, window_s));
        record(runLiggghtsRanks(file, static_cast<std::uint64_t>(seed), cores, window_s));
      }

    // Per backend and core count: speed and draught, mean and sample standard deviation over seeds.
    nlohmann::json summary = nlohmann::json::object();
    for (int cores : {1, 2}) {
      double speed[2] = {0, 0};
      for (const std::string backend : {"builtin", "liggghts"}) {
        std::vector<double> draught, rate;
        for (const auto& r : runs)
          if (r.backend == backend && r.cores == cores) {
            draught.push_back(r.draught_N);
            rate.push_back(r.particleStepsPerSecond());
          }
        const Summary d = summarise(draught), v = summarise(rate);
        speed[backend == "builtin" ? 0 : 1] = v.mean;
        std::printf("%-9s %d core(s), %d seeds: %.3e +- %.1e particle-steps/s, draught %.4f +- %.4f N\n",
                    backend.c_str(), cores, seeds, v.mean, v.stddev, d.mean, d.stddev);
        summary[backend + "_" + std::to_string(cores) + "_cores"] = {{"particle_steps_per_s_mean", v.mean},
                                                                   {"particle_steps_per_s_stddev", v.stddev},
                                                                   {"draught_mean_N", d.mean},
                                                                   {"draught_stddev_N", d.stddev}};
      }
      std::printf("speed ratio liggghts / builtin on %d core(s): %.3f\n", cores, speed[1] / speed[0]);
      summary["speed_ratio_liggghts_over_builtin_" + std::to_string(cores) + "_cores"] = speed[1] / speed[0];
    }
    nlohmann::json all = nlohmann::json::array();
    for (const auto& r : runs) all.push_back(toJson(r));
    cli::writeJson(json_target, {{"study", file},
                                 {"window_s", window_s},
                                 {"interval_s", g_interval_s},
                                 {"settle_kinetic_energy_J", benchStudy(file, 1, 1).soil.settle_kinetic_energy_J},
                                 {"liggghts_on_builtin_soil", g_liggghts_on_builtin_soil},
                                 {"runs", all},
                                 {"summary", summary}});
  });
  return cli::runApp(app, argc, argv);
}
