// `demfem deposit STUDY`: deposits and settles a study's soil once with the built-in DEM and saves it
// where every study on the same soil finds it (by soil hash).
#include "commands.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

namespace demfem::cli {

namespace {
struct DepositOptions {
  std::string study_file;
  std::string soil_dir;
  int threads = 0;
  bool force = false;
  bool quiet = false;
};
}  // namespace

void addDepositCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "deposit",
      "Deposit the soil of a study by gravity in layers with the built-in DEM, settle it below the study's "
      "kinetic-energy threshold and save it as soil-<hash>.bin (the hash covers everything that determines the "
      "soil). Runs reuse the file; an existing file is kept unless --force.");
  auto opt = std::make_shared<DepositOptions>();
  cmd->add_option("STUDY", opt->study_file, "Study file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--soil-dir", opt->soil_dir, "Directory of settled soils (default: $DEMFEM_SOIL_DIR or ./soil)");
  cmd->add_option("--threads", opt->threads, "OpenMP threads (default: the study's /dem/threads)")->check(CLI::PositiveNumber);
  cmd->add_flag("--force", opt->force, "Deposit again even if the file exists");
  cmd->add_flag("--quiet", opt->quiet, "No progress output");
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([opt, &json_target] {
    const study::Study s = study::loadStudy(opt->study_file);
    const std::filesystem::path dir =
        opt->soil_dir.empty() ? builtin::defaultSoilDirectory() : std::filesystem::path(opt->soil_dir);
    const auto file = builtin::soilFile(s, dir);
    const bool text = textOnStdout(json_target);
    nlohmann::json report{{"study", opt->study_file}, {"soil_file", file.string()}, {"soil_hash", study::soilHash(s)}};
    if (std::filesystem::exists(file) && !opt->force) {
      const auto soil = builtin::readSettledSoil(file);
      if (text) std::cout << file.string() << ": already deposited (" << soil.particles.size() << " particles)\n";
      report["reused"] = true;
      report["particles"] = soil.particles.size();
      writeJson(json_target, report);
      return;
    }
    const int threads = opt->threads > 0 ? opt->threads : s.dem.threads;
    builtin::DepositReport r;
    const auto start = std::chrono::steady_clock::now();
    Progress progress("deposition", !opt->quiet);
    const auto soil = builtin::depositSoil(s, threads, r, [&](double fraction, const std::string& stage_line) {
      if (!stage_line.empty() && !opt->quiet) std::cerr << "deposition: " << stage_line << std::endl;
      progress.update(fraction);
    });
    progress.finish(std::to_string(r.particles) + " particles");
    builtin::writeSettledSoil(file, soil);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (text)
      std::cout << file.string() << ": " << r.particles << " particles, surface at " << r.surface_height_m * 1e3
                << " mm, " << r.steps << " steps of " << r.time_step_s << " s (" << r.simulated_s << " s simulated, "
                << wall_s << " s wall)" << (r.settled ? "" : "; WARNING: a stage hit its time cap before settling")
                << '\n';
    report["reused"] = false;
    report["particles"] = r.particles;
    report["surface_height_mm"] = r.surface_height_m * 1e3;
    report["steps"] = r.steps;
    report["time_step_s"] = r.time_step_s;
    report["simulated_s"] = r.simulated_s;
    report["wall_time_s"] = wall_s;
    report["final_kinetic_energy_J"] = r.final_kinetic_energy_J;
    report["settled"] = r.settled;
    writeJson(json_target, report);
  });
}

}  // namespace demfem::cli
