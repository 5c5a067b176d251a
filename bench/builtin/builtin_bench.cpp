// builtin_bench: speed of the built-in DEM on a settled soil bin with a plate tool dragged through it
// (issue: built-in DEM backend; the bar is LIGGGHTS 3.8 on the same case: about 6 M particle-steps/s
// on 1 core and 11.5 M on 2 ranks with hooke + tangential history + cdt, 4.9 M with
// hooke/hysteresis + sjkr + epsd).
//
// Every contact model is timed on a bin settled WITH THAT MODEL: a packing settled with one law is
// not at rest under another (the EDEM spring's K1 = 5 R* Y is about 100 times softer than hooke's kn
// at this E), and timing a bin that is springing apart measures the wrong contact count. Each
// model's soil is deposited once (cached as soil-<hash>.bin in the soil directory; the hash covers
// the contact model and time step), with the DEM step at a tenth of the model's stiffest-spring
// critical step, the same step the drag is timed with, settled to a total kinetic energy of 1e-3 J
// (--settle-J: timing needs a bin at rest, not a study's 1e-6 J, which the soft EDEM spring never
// reaches within the deposition's time cap). The tool is inserted to its depth (untimed), then
// every thread count is timed over the same number of drag steps from that same state, with the
// process CPU time beside the wall time. Within a round the thread counts take turns every
// --slice-steps steps (1 2, 2 1, 1 2, ...), so that a machine whose speed drifts, as a VM's does
// by 10 % within seconds, slows every count alike and their ratio holds still; the first
// --warmup-steps of each simulation are not timed (10 by default: its lists and first forces;
// about 130 also leave out the thread team's first timing of its two ways of running a phase, a
// cost once per simulation). With --compete each count is also timed beside a competing busy
// process (one more runnable process than the 2 cores hold), which is where a spinning thread team
// collapses. With --twin each round also times two copies of the 1-thread run in
// two processes at once: the work of both over the time the slower took is what the machine's two
// cores give when nothing is shared but the hardware (caches, memory, and on a VM whatever the host
// shares), the ceiling for 2 threads. Prints a table of every timing and the medians and ratios per
// round; --json FILE writes the figures (units in the keys) with the load average before and after.
#include "bench_statistics.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/builtin/vector_isa.hpp"
#include "demfem/backends/physics/time_step.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/study/study.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

using namespace demfem;
using namespace demfem::builtin;

namespace {

constexpr double kInsertionVelocity_m_s = 0.3;

struct ModelCase {
  std::string label;
  study::ContactModel model;
};

TriangleMesh plateMesh(const study::Tool& tool, int material) {
  TriangleMesh mesh = toolMesh(tool);
  mesh.material = material;
  return mesh;
}

// The bin with the settled particles (states given) and the tool at depth moving at its velocity.
DemSimulation makeBin(const study::Study& st, const std::vector<ParticleState>& particles, int threads, Vec3 tool_origin) {
  const study::Soil& soil = st.soil;
  DemSimulation sim(soil, binDomain(soil), threads);
  addBinWalls(sim, soil);
  for (const auto& p : particles) sim.addParticle(p);
  const auto& tool = st.tools.at(0);
  const int m = sim.addMesh(plateMesh(tool, sim.materials().index(tool.dem_material)));
  sim.setMeshMotion(m, tool_origin, {0, 0, tool.motion.velocity_m_s}, 0);
  return sim;
}

// A busy process beside the timed run (stopped and reaped by its destructor).
class Competitor {
 public:
  Competitor() : pid_(::fork()) {
    if (pid_ < 0) throw std::runtime_error("--compete: fork failed");
    if (pid_ == 0) {
      volatile double x = 1;
      for (;;) x = x * 1.0000001 + 1e-9;
    }
  }
  Competitor(const Competitor&) = delete;
  Competitor& operator=(const Competitor&) = delete;
  ~Competitor() {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }

 private:
  pid_t pid_;
};

double loadAverage() {
  std::ifstream in("/proc/loadavg");
  double one = std::nan("");
  in >> one;
  return one;
}

struct Timing {
  double wall_s = 0, cpu_s = 0, rate = 0;
};

// How a variant runs: alone, beside a competing busy process, or as one of two 1-thread copies in
// two processes at once (the ceiling for 2 threads).
enum class Mode { Alone, BesideBusy, Twin };

const char* modeName(Mode m) {
  switch (m) {
    case Mode::Alone: return "no";
    case Mode::BesideBusy: return "yes";
    case Mode::Twin: return "twin";
  }
  return "?";
}

const char* modeSentence(Mode m) {
  switch (m) {
    case Mode::Alone: return "";
    case Mode::BesideBusy: return " beside a competing process";
    case Mode::Twin: return " as two 1-thread processes at once (both counted)";
  }
  return "";
}

// Processor time of every thread of this process so far.
double processCpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

// Times `steps` steps of each simulation of `sims` (one per thread count, from the same state),
// beside a competing busy process if `compete`, in turns of `slice` steps (A B, B A, A B, ...):
// per simulation the wall time and the process CPU time of all threads over its turns (only one
// simulation runs at a time; the competitor is another process, and on a shared machine wall time
// also counts the waiting for a core).
std::vector<Timing> timeInTurns(std::vector<DemSimulation>& sims, long steps, long slice, bool compete) {
  std::unique_ptr<Competitor> competitor;
  if (compete) competitor = std::make_unique<Competitor>();
  std::vector<Timing> timings(sims.size());
  long turn = 0;
  for (long done = 0; done < steps; done += slice, ++turn) {
    const long n = std::min(slice, steps - done);
    for (std::size_t k = 0; k < sims.size(); ++k) {
      const std::size_t s = turn % 2 == 0 ? k : sims.size() - 1 - k;
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = processCpuSeconds();
      sims[s].run(n);
      timings[s].wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      timings[s].cpu_s += processCpuSeconds() - c0;
    }
  }
  for (std::size_t s = 0; s < sims.size(); ++s)
    timings[s].rate = static_cast<double>(sims[s].particleCount()) * static_cast<double>(steps) / timings[s].wall_s;
  return timings;
}

// Runs `steps` steps of `sim` (1 thread: no team threads to lose in the fork) here and in a forked
// copy at the same moment: the wall time until both are done and the processor time of both.
Timing runTwins(DemSimulation& sim, long steps) {
  int go[2], result[2];
  if (::pipe(go) != 0 || ::pipe(result) != 0) throw std::runtime_error("--twin: pipe failed");
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("--twin: fork failed");
  if (pid == 0) {  // the twin: wait for the start, run, send back its processor time
    char start = 0;
    if (::read(go[0], &start, 1) == 1) {
      const double c0 = processCpuSeconds();
      sim.run(steps);
      const double cpu_s = processCpuSeconds() - c0;
      if (::write(result[1], &cpu_s, sizeof cpu_s) != static_cast<ssize_t>(sizeof cpu_s)) ::_exit(1);
    }
    ::_exit(0);
  }
  ::close(go[0]);
  ::close(result[1]);
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = processCpuSeconds();
  bool started = ::write(go[1], "g", 1) == 1;
  double twin_cpu_s = 0;
  Timing t;
  if (started) {
    sim.run(steps);
    t.cpu_s = processCpuSeconds() - c0;
    started = ::read(result[0], &twin_cpu_s, sizeof twin_cpu_s) == static_cast<ssize_t>(sizeof twin_cpu_s);
    t.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  ::close(go[1]);
  ::close(result[0]);
  if (!started) ::kill(pid, SIGKILL);
  ::waitpid(pid, nullptr, 0);
  if (!started) throw std::runtime_error("--twin: the twin process did not run or report its timing");
  t.cpu_s += twin_cpu_s;
  t.rate = 2 * static_cast<double>(sim.particleCount()) * static_cast<double>(steps) / t.wall_s;
  return t;
}


}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"builtin_bench: particle-steps per second of the built-in DEM on a settled bin with a moving tool"};
  std::string study_file = "studies/paper/s235_dem_18.json";
  std::string soil_dir;
  long steps = 2000;
  std::vector<int> thread_counts{1, 2};
  app.add_option("--study", study_file, "Study with the bin, soil and tool (default studies/paper/s235_dem_18.json)")
      ->check(CLI::ExistingFile);
  app.add_option("--soil-dir", soil_dir, "Directory of settled soils (default: $DEMFEM_SOIL_DIR or ./soil)");
  app.add_option("--steps", steps, "Timed drag steps per case")->check(CLI::PositiveNumber);
  app.add_option("--threads", thread_counts, "Thread counts to time");
  double settle_J = 1e-3;
  app.add_option("--settle-J", settle_J,
                 "Kinetic energy (J) below which the benchmark soil counts as settled")
      ->check(CLI::PositiveNumber);
  int rounds = 3;
  app.add_option("--rounds", rounds, "Rounds: every thread count once per round")->check(CLI::PositiveNumber);
  long slice_steps = 250;
  app.add_option("--slice-steps", slice_steps, "Steps per turn: within a round the thread counts take turns (default 250)")
      ->check(CLI::PositiveNumber);
  long warmup_steps = 10;
  app.add_option("--warmup-steps", warmup_steps,
                 "Untimed steps of each simulation before its timing (default 10: its lists and first forces; about 130 "
                 "also leave out the thread team's first timing of its two ways)")
      ->check(CLI::NonNegativeNumber);
  bool compete = false;
  app.add_flag("--compete", compete, "Also time every thread count beside a competing busy process");
  bool twin = false;
  app.add_flag("--twin", twin, "Also time two 1-thread runs in two processes at once (the ceiling for 2 threads)");
  std::vector<std::string> only;
  app.add_option("--model", only, "Time only these models (labels as printed; default: all)");
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    const study::Study base = study::loadStudy(study_file);
    if (base.tools.empty()) throw cli::InputError(study_file + ": the benchmark needs a tool");
    const auto& tool = base.tools[0];
    const std::filesystem::path dir = soil_dir.empty() ? adapter::defaultSoilDirectory() : std::filesystem::path(soil_dir);

    study::ContactModel edem = base.soil.contact;
    edem.normal = study::NormalModel::EdemHysteretic;
    edem.cohesion = study::CohesionModel::EdemLinear;
    edem.rolling = study::RollingModel::EdemStandard;
    study::ContactModel hooke = base.soil.contact;
    hooke.normal = study::NormalModel::Hooke;
    hooke.cohesion = study::CohesionModel::None;
    hooke.rolling = study::RollingModel::Cdt;
    hooke.tangential_history = true;
    study::ContactModel luding = hooke;
    luding.normal = study::NormalModel::HookeHysteresis;
    luding.cohesion = study::CohesionModel::Sjkr;
    luding.rolling = study::RollingModel::Epsd;
    const std::vector<ModelCase> cases{{"hysteretic+linear-cohesion+edem-rolling", edem},
                                       {"hooke+history+cdt", hooke},
                                       {"hooke/hysteresis+sjkr+epsd", luding}};

    nlohmann::json report{{"study", study_file},
                          {"steps", steps},
                          {"rounds", rounds},
                          {"slice_steps", slice_steps},
                          {"warmup_steps", warmup_steps},
                          {"load_average_1min_start", loadAverage()},
                          {"vector_isa", vectorIsaName(vectorIsa())},
                          {"cases", nlohmann::json::array()},
                          {"summary", nlohmann::json::array()}};
    const bool text = json_target != "-";
    if (text)
      std::printf("tool at %.0f mm depth moving at %.2f mm/s, %ld steps per case, each model on its own settled bin; "
                  "pair loop on %s\n\n",
                  tool.motion.depth_m * 1e3, tool.motion.velocity_m_s * 1e3, steps, vectorIsaName(vectorIsa()));
    if (text)
      std::printf("%-42s %9s %7s %8s %5s %11s %9s %9s %16s %10s %9s %7s\n", "model", "particles", "threads", "compete",
                  "round", "dt_s", "wall_s", "cpu_s", "particle_steps/s", "bytes/part", "contacts", "alone%");
    for (const auto& label : only)
      if (std::none_of(cases.begin(), cases.end(), [&](const ModelCase& c) { return c.label == label; }))
        throw cli::InputError("--model: unknown model '" + label + "'");
    for (const auto& c : cases) {
      if (!only.empty() && std::find(only.begin(), only.end(), c.label) == only.end()) continue;
      study::Study st = base;
      st.soil.contact = c.model;
      st.dem.dt_s.reset();
      st.dem.criterion = study::TimeStepCriterion::StiffestSpring;
      st.dem.dt_fraction = 0.1;
      st.soil.settle_kinetic_energy_J = settle_J;
      const auto file = adapter::settledSoilFile(st, dir);
      adapter::SettledSoil settled;
      if (std::filesystem::exists(file)) {
        settled = adapter::readSettledSoil(file, st);
      } else {
        std::cerr << c.label << ": depositing " << file.string() << " (once)\n";
        DepositReport r;
        settled = depositSoil(st, 2, r, [](double, const std::string& line) {
          if (!line.empty()) std::cerr << line << '\n';
        });
        adapter::writeSettledSoil(file, settled);
      }
      // Insert the tool with this model (untimed, at 0.3 m/s, as the LIGGGHTS benchmark does, to keep it
      // short) and keep the particle states.
      std::vector<ParticleState> states;
      Vec3 origin;
      {
        DemSimulation sim(st.soil, binDomain(st.soil), 2);
        addBinWalls(sim, st.soil);
        addSettledParticles(sim, st.soil, settled);
        const double travel = 0.005 + tool.motion.depth_m;
        const int m = sim.addMesh(plateMesh(tool, sim.materials().index(tool.dem_material)));
        sim.setMeshMotion(m, {st.soil.bin_width_m / 2, st.soil.fill_height_m + 0.005, tool.motion.start_z_m - tool.geometry.thickness_m / 2},
                          {0, -kInsertionVelocity_m_s, 0}, sim.time());
        sim.setTimeStep(physics::demTimeStep(st).step_s);
        sim.run(std::lround(travel / kInsertionVelocity_m_s / sim.timeStep()));
        for (std::size_t i = 0; i < sim.particleCount(); ++i) states.push_back(sim.particle(i));
        origin = sim.mesh(m).offset(sim.time());
      }
      // Per round: the thread counts in turns, alone and with --compete beside a busy process, then
      // with --twin the two 1-thread processes; every simulation from the same soil state.
      std::vector<Mode> modes{Mode::Alone};
      if (compete) modes.push_back(Mode::BesideBusy);
      std::map<std::pair<int, Mode>, std::vector<Timing>> timings;
      // Warmed up where it is timed: a simulation moved or copied gets a new thread team, which
      // starts its timing of the two ways afresh.
      const auto warmUp = [&](DemSimulation& sim) {
        sim.setTimeStep(physics::demTimeStep(st).step_s);
        sim.run(warmup_steps);
      };
      const auto record = [&](const DemSimulation& sim, int threads, Mode mode, int round, const Timing& t) {
        timings[{threads, mode}].push_back(t);
        if (text)
          std::printf("%-42s %9zu %7d %8s %5d %11.3e %9.2f %9.2f %16.3e %10zu %9zu %7.1f\n", c.label.c_str(), sim.particleCount(),
                      threads, modeName(mode), round + 1, sim.timeStep(), t.wall_s, t.cpu_s, t.rate, sim.bytesPerParticle(),
                      sim.contactCount(), 100.0 * static_cast<double>(sim.teamPhasesAlone()) / std::max(1L, sim.teamPhases()));
        report["cases"].push_back({{"model", c.label},
                                   {"particles", sim.particleCount()},
                                   {"threads", threads},
                                   {"competing_process", mode == Mode::BesideBusy},
                                   {"twin_processes", mode == Mode::Twin},
                                   {"round", round + 1},
                                   {"dt_s", sim.timeStep()},
                                   {"simulated_time_s", sim.time()},
                                   {"wall_s", t.wall_s},
                                   {"cpu_s", t.cpu_s},
                                   {"particle_steps_per_s", t.rate},
                                   {"bytes_per_particle", sim.bytesPerParticle()},
                                   {"contacts", sim.contactCount()},
                                   {"team_phases", sim.teamPhases()},
                                   {"team_phases_alone", sim.teamPhasesAlone()}});
      };
      for (int round = 0; round < rounds; ++round) {
        for (const Mode mode : modes) {
          std::vector<DemSimulation> sims;
          sims.reserve(thread_counts.size());
          for (const int threads : thread_counts) sims.push_back(makeBin(st, states, threads, origin));
          for (auto& sim : sims) warmUp(sim);
          const std::vector<Timing> t = timeInTurns(sims, steps, slice_steps, mode == Mode::BesideBusy);
          for (std::size_t k = 0; k < sims.size(); ++k) record(sims[k], thread_counts[k], mode, round, t[k]);
        }
        if (twin) {
          DemSimulation sim = makeBin(st, states, 1, origin);
          warmUp(sim);
          record(sim, 1, Mode::Twin, round, runTwins(sim, steps));
        }
      }
      // Per variant: median rate; against the first thread count of the same round (beside the
      // competitor for the variants beside it, alone for the rest): the ratio per round, its median
      // and its smallest value.
      for (const auto& [variant, list] : timings) {
        const Mode base_mode = variant.second == Mode::BesideBusy ? Mode::BesideBusy : Mode::Alone;
        const auto& base = timings[{thread_counts.front(), base_mode}];
        std::vector<double> rates, ratios;
        for (std::size_t r = 0; r < list.size(); ++r) {
          rates.push_back(list[r].rate);
          ratios.push_back(list[r].rate / base[r].rate);
        }
        const double med = bench::median(rates), ratio = bench::median(ratios), worst = *std::min_element(ratios.begin(), ratios.end());
        if (text)
          std::printf("%s, %d thread(s)%s: median %.3e particle-steps/s; over %d thread(s) in the same round: median %.2fx, "
                      "lowest %.2fx\n",
                      c.label.c_str(), variant.first, modeSentence(variant.second), med, thread_counts.front(), ratio, worst);
        report["summary"].push_back({{"model", c.label},
                                     {"threads", variant.first},
                                     {"competing_process", variant.second == Mode::BesideBusy},
                                     {"twin_processes", variant.second == Mode::Twin},
                                     {"median_particle_steps_per_s", med},
                                     {"median_ratio_to_first_thread_count", ratio},
                                     {"lowest_ratio_to_first_thread_count", worst}});
      }
    }
    report["load_average_1min_end"] = loadAverage();
    cli::writeJson(json_target, report);
  });
  return cli::runApp(app, argc, argv);
}
