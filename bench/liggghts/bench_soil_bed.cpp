// Soil-bed benchmark: the built-in DEM's gravity pour against LIGGGHTS' own deposition
// (insert/pack) of the same study, several seeds: particle count, packing fraction, bulk density
// and mean coordination number of each settled soil (adapter/settled_soil.hpp: the figures are
// computed from the soil files alike for both engines), their mean and standard deviation over the
// seeds, and the built-in DEM's means over LIGGGHTS' against the targets (count and packing
// fraction within 1.5 %, coordination number within 5 %). Prints a table; --json writes the same
// numbers.
// --rest-s T: each built-in bed is then left alone for T s of simulated time with the study's laws
// at the run's step (no settling aid), and its rms particle speed at the end and largest particle
// displacement are reported (a bed at rest: below 0.3 mm/s and 1 mm after 2 s); --rest-vtk DIR
// also writes that rest as a run writes its particle files, the rest run of `demfem soil-motion
// --rest-run`.
//
// Soils are kept by hash in --soil-dir (a scratch directory: default a new one under the system's
// temporary directory) and reused unless --force: LIGGGHTS' soils do not change when the built-in
// deposition does. Both engines deposit in this process (LIGGGHTS on one MPI rank, the built-in DEM
// on --threads threads); depositions are long phases and show their progress on stderr.
#include "bench_statistics.hpp"
#include "demfem/adapter/output_files.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/study/study.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <unistd.h>
#include <vector>

namespace {

using namespace demfem;

struct Bed {
  std::string backend;
  std::uint64_t seed = 1;
  std::size_t particles = 0;
  double packing_fraction = 0, bulk_density_kg_m3 = 0, coordination_number = 0, surface_mm = 0, simulated_s = 0;
  double wall_s = 0;  // NaN when the soil file was reused
  bool settled = false;
  double rest_rms_speed_mm_s = std::nan(""), rest_max_displacement_mm = std::nan("");  // --rest-s
  double rest_late_max_displacement_mm = std::nan("");  // over the second half of the rest only
  std::size_t rest_moved_1mm = 0;                        // particles displaced more than 1 mm
};

// Leaves the bed alone for `rest_s` (builtin::measureRest: loaded as a run loads it, the study's
// laws at the run's step) and keeps its figures. With `vtk_dir` the particles are written there as a
// run writes them (vtk/particles.pvd, a file every output.vtk_every FEM steps, named by the FEM
// step): the rest run `demfem soil-motion --rest-run` takes velocities against.
void measureRest(const study::Study& s, const adapter::SettledSoil& soil, double rest_s, int threads, const std::filesystem::path& vtk_dir,
                 Bed& bed) {
  const double every_s = s.output.vtk_every > 0 ? s.output.vtk_every * s.fem.dt_s : 0.0;
  std::optional<adapter::VtkSeries> series;
  if (!vtk_dir.empty()) {
    if (!(every_s > 0)) throw std::invalid_argument("--rest-vtk: the study writes no particle files (output.vtk_every)");
    std::filesystem::create_directories(vtk_dir / "vtk");
    series.emplace(vtk_dir / "vtk" / "particles.pvd");
  }
  const auto rest = builtin::measureRest(
      s, soil, rest_s, threads,
      [&](const builtin::DemSimulation& sim) {
        if (series) {
          char name[40];
          std::snprintf(name, sizeof name, "particles_%06lld.vtp", static_cast<long long>(std::llround(sim.time() / s.fem.dt_s)));
          sim.writeParticlesVtk(vtk_dir / "vtk" / name);
          series->add(sim.time(), name);
        }
        std::cerr << "  rest: " << sim.time() << " s of " << rest_s << " s\r" << std::flush;
      },
      every_s);
  std::cerr << '\n';
  bed.rest_rms_speed_mm_s = 1e3 * rest.rms_speed_m_s;
  bed.rest_max_displacement_mm = 1e3 * rest.largest_displacement_m;
  bed.rest_late_max_displacement_mm = 1e3 * rest.largest_late_displacement_m;
  bed.rest_moved_1mm = rest.moved_over_1mm;
}

struct Stats {
  double mean = 0, std_dev = 0;
};

Stats stats(const std::vector<double>& v) {
  Stats s;
  for (const double x : v) s.mean += x;
  s.mean /= static_cast<double>(v.size());
  for (const double x : v) s.std_dev += (x - s.mean) * (x - s.mean);
  s.std_dev = v.size() > 1 ? std::sqrt(s.std_dev / static_cast<double>(v.size() - 1)) : 0.0;
  return s;
}

Bed depositOrReuse(study::Study s, const std::string& backend, std::uint64_t seed, int threads,
                   const std::filesystem::path& dir, bool force, double rest_s, const std::string& rest_vtk) {
  s.soil.deposition_backend = backend;
  s.soil.deposition_seed = seed;
  const auto file = adapter::settledSoilFile(s, dir);
  Bed bed;
  bed.backend = backend;
  bed.seed = seed;
  bed.wall_s = std::nan("");
  adapter::SettledSoil soil;
  if (std::filesystem::exists(file) && !force) {
    soil = adapter::readSettledSoil(file, s);
  } else {
    std::cerr << "deposit: " << backend << ", seed " << seed << '\n';
    const auto start = std::chrono::steady_clock::now();
    if (backend == "liggghts") {
      soil = liggghts::depositSoil(s);
    } else {
      builtin::DepositReport report;
      int shown = -1;  // the last percentage shown
      soil = builtin::depositSoil(s, threads, report, [&shown](double fraction, const std::string& line) {
        const int percent = static_cast<int>(100 * fraction);
        if (!line.empty()) {
          std::cerr << "  " << line << '\n';
        } else if (percent >= shown + 5) {
          shown = percent;
          std::cerr << "  " << percent << " %\r" << std::flush;
        }
      });
    }
    bed.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    adapter::writeSettledSoil(file, soil);
  }
  bed.particles = soil.particles.size();
  bed.packing_fraction = adapter::packingFraction(soil.particles, s.soil);
  bed.bulk_density_kg_m3 = adapter::bulkDensity(soil.particles, s.soil);
  bed.coordination_number = adapter::meanCoordinationNumber(soil.particles);
  bed.surface_mm = soil.settling.surface_height_m * 1e3;
  bed.simulated_s = soil.settling.simulated_s;
  bed.settled = adapter::unsettledReason(soil.settling).empty();
  if (rest_s > 0 && backend == "builtin")
    measureRest(s, soil, rest_s, threads, rest_vtk.empty() ? std::filesystem::path() : std::filesystem::path(rest_vtk) / ("seed-" + std::to_string(seed)),
                bed);
  return bed;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-soil-bed: the built-in gravity pour against LIGGGHTS' deposition, several seeds"};
  app.name("demfem-bench-soil-bed");
  std::string file = std::string(DEMFEM_SOURCE_DIR) + "/studies/quick_liggghts.json";
  int seeds = 3, threads = 1;
  std::string soil_dir;
  bool force = false;
  double rest_s = 0;
  std::string rest_vtk;
  std::vector<std::string> backends{"builtin", "liggghts"};
  app.add_option("--study", file, "Study file (default: studies/quick_liggghts.json)")->check(CLI::ExistingFile);
  app.add_option("--seeds", seeds, "Deposition seeds 1..N")->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "Threads of the built-in deposition")->check(CLI::PositiveNumber);
  app.add_option("--soil-dir", soil_dir, "Directory of the soils (reused by hash; default: a new temporary one)");
  app.add_option("--backends", backends, "Engines that deposit")->check(CLI::IsMember({"builtin", "liggghts"}));
  app.add_option("--rest-s", rest_s, "Leave each built-in bed alone this long (s) and report its rest state")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rest-vtk", rest_vtk,
                 "With --rest-s: write each built-in bed's rest as a run writes its particles, to DIR/seed-N (for demfem soil-motion --rest-run)");
  app.add_flag("--force", force, "Deposit again even where the soil file exists");
  std::string& json_target = cli::addJsonOption(app);
  CLI11_PARSE(app, argc, argv);
  try {
    const study::Study base = study::loadStudy(file);
    const std::filesystem::path dir =
        soil_dir.empty() ? std::filesystem::temp_directory_path() / ("demfem-bench-soil-bed-" + std::to_string(::getpid()))
                         : std::filesystem::path(soil_dir);
    std::vector<Bed> beds;
    for (int seed = 1; seed <= seeds; ++seed)
      for (const auto& backend : backends) beds.push_back(depositOrReuse(base, backend, static_cast<std::uint64_t>(seed), threads, dir, force, rest_s, rest_vtk));

    const bool text = cli::textOnStdout(json_target);
    if (text) {
      std::printf("%s, soils in %s\n%-9s %5s %9s %8s %11s %8s %9s %9s %s\n", file.c_str(), dir.string().c_str(), "backend",
                  "seed", "particles", "packing", "bulk_kg_m3", "coord", "surf_mm", "wall_s", "settled");
      for (const Bed& b : beds) {
        std::printf("%-9s %5llu %9zu %8.4f %11.1f %8.3f %9.2f %9.1f %s", b.backend.c_str(),
                    static_cast<unsigned long long>(b.seed), b.particles, b.packing_fraction, b.bulk_density_kg_m3,
                    b.coordination_number, b.surface_mm, b.wall_s, b.settled ? "yes" : "NO");
        if (!std::isnan(b.rest_rms_speed_mm_s))
          std::printf("  after %.2f s alone: rms speed %.4f mm/s, largest displacement %.4f mm (%zu particles > 1 mm; "
                      "largest over the second half %.4f mm)",
                      rest_s, b.rest_rms_speed_mm_s, b.rest_max_displacement_mm, b.rest_moved_1mm,
                      b.rest_late_max_displacement_mm);
        std::printf("\n");
      }
    }
    nlohmann::json report{{"study", file}, {"seeds", seeds}, {"builtin_threads", threads}, {"soil_dir", dir.string()}};
    nlohmann::json runs = nlohmann::json::array();
    for (const Bed& b : beds)
      runs.push_back({{"backend", b.backend}, {"seed", b.seed}, {"particles", b.particles},
                      {"packing_fraction", b.packing_fraction}, {"bulk_density_kg_m3", b.bulk_density_kg_m3},
                      {"coordination_number", b.coordination_number}, {"surface_height_mm", b.surface_mm},
                      {"simulated_s", b.simulated_s},
                      {"wall_s", std::isnan(b.wall_s) ? nlohmann::json() : nlohmann::json(b.wall_s)},
                      {"settled", b.settled},
                      {"rest_s", rest_s},
                      {"rest_rms_speed_mm_s", std::isnan(b.rest_rms_speed_mm_s) ? nlohmann::json() : nlohmann::json(b.rest_rms_speed_mm_s)},
                      {"rest_max_displacement_mm",
                       std::isnan(b.rest_max_displacement_mm) ? nlohmann::json() : nlohmann::json(b.rest_max_displacement_mm)},
                      {"rest_second_half_max_displacement_mm",
                       std::isnan(b.rest_late_max_displacement_mm) ? nlohmann::json() : nlohmann::json(b.rest_late_max_displacement_mm)},
                      {"rest_particles_moved_over_1mm", b.rest_moved_1mm}});
    report["runs"] = runs;
    std::map<std::string, std::map<std::string, Stats>> summary;
    for (const auto& backend : backends) {
      std::vector<double> n, phi, rho, z;
      for (const Bed& b : beds)
        if (b.backend == backend)
          n.push_back(static_cast<double>(b.particles)), phi.push_back(b.packing_fraction),
              rho.push_back(b.bulk_density_kg_m3), z.push_back(b.coordination_number);
      summary[backend] = {{"particles", stats(n)}, {"packing_fraction", stats(phi)}, {"bulk_density_kg_m3", stats(rho)},
                          {"coordination_number", stats(z)}};
      for (const auto& [key, st] : summary[backend]) report["summary"][backend][key] = {{"mean", st.mean}, {"std_dev", st.std_dev}};
      if (text)
        std::printf("%-9s mean over %d seeds: %.1f +- %.1f particles, packing %.4f +- %.4f, %.1f +- %.1f kg/m3, "
                    "coordination %.3f +- %.3f\n",
                    backend.c_str(), seeds, summary[backend]["particles"].mean, summary[backend]["particles"].std_dev,
                    summary[backend]["packing_fraction"].mean, summary[backend]["packing_fraction"].std_dev,
                    summary[backend]["bulk_density_kg_m3"].mean, summary[backend]["bulk_density_kg_m3"].std_dev,
                    summary[backend]["coordination_number"].mean, summary[backend]["coordination_number"].std_dev);
    }
    if (summary.count("builtin") && summary.count("liggghts")) {
      // The targets: count and packing fraction within 1.5 %, coordination within 5 %.
      const std::vector<std::pair<std::string, double>> targets{
          {"particles", 0.015}, {"packing_fraction", 0.015}, {"coordination_number", 0.05}};
      bool all = true;
      for (const auto& [key, tolerance] : targets) {
        const double ratio = summary["builtin"][key].mean / summary["liggghts"][key].mean;
        const bool within = std::abs(ratio - 1) <= tolerance;
        all = all && within;
        report["builtin_over_liggghts"][key] = {{"ratio", ratio}, {"tolerance", tolerance}, {"within", within}};
        if (text) std::printf("builtin / liggghts %-20s %.4f (target 1 +- %.3f): %s\n", key.c_str(), ratio, tolerance, within ? "within" : "OUTSIDE");
      }
      report["within_targets"] = all;
    }
    cli::writeJson(json_target, report);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "demfem-bench-soil-bed: %s\n", e.what());
    return 1;
  }
  return 0;
}
