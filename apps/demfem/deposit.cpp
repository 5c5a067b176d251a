// `demfem deposit STUDY [--backend builtin|liggghts]`: deposits and settles a study's soil once and
// saves it as the backend-neutral settled-soil file (adapter/settled_soil.hpp) that every run of a
// study on the same soil, on either DEM backend, starts from.
#include "commands.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/soil_supply.hpp"
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
  std::string backend;
  int threads = 0;
  bool force = false;
  bool quiet = false;
};

// The command's report: the soil record a run keeps (adapter::soilRecordJson, its "file" named
// "soil_file" here), the study and whether the file was reused.
nlohmann::json reportJson(const std::string& study_file, const std::filesystem::path& file, const adapter::SettledSoil& soil,
                          bool reused) {
  nlohmann::json report = nlohmann::json::parse(adapter::soilRecordJson(soil, file, adapter::settledSoilChecksum(file)));
  report.erase("file");
  report["soil_file"] = file.string();
  report["study"] = study_file;
  report["reused"] = reused;
  return report;
}

void printSoil(const std::filesystem::path& file, const adapter::SettledSoil& soil) {
  const auto& s = soil.settling;
  const std::string reason = adapter::unsettledReason(s);
  std::cout << file.string() << ": " << soil.particles.size() << " particles deposited by "
            << soil.backend << " (seed " << soil.seed << "), surface at "
            << s.surface_height_m * 1e3 << " mm, packing fraction " << s.packing_fraction << ", bulk density "
            << s.bulk_density_kg_m3 << " kg/m3"
            << (s.target_bulk_density_kg_m3 > 0 ? " (stated " : "");
  if (s.target_bulk_density_kg_m3 > 0) std::cout << s.target_bulk_density_kg_m3 << " kg/m3)";
  std::cout << ", coordination number " << s.coordination_number << ", kinetic energy "
            << s.kinetic_energy_J << " J (threshold " << s.threshold_J << " J), " << s.stages_capped << " of "
            << s.stages << " stages capped" << (reason.empty() ? "" : "; NOT SETTLED: " + reason) << '\n';
}
}  // namespace

void addDepositCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "deposit",
      "Deposit the soil of a study by gravity in layers, settle it below the study's kinetic-energy threshold and "
      "save it as soil-<hash>.bin, the settled soil both DEM backends start from (the hash covers everything that "
      "determines the soil, including the deposition backend). Runs reuse the file; an existing file is kept "
      "unless --force. An unsettled soil is saved with its figures; runs refuse it unless --allow-unsettled-soil.");
  auto opt = std::make_shared<DepositOptions>();
  cmd->add_option("STUDY", opt->study_file, "Study file (JSON)")->required()->check(CLI::ExistingFile);
  std::vector<std::string> soil_backends;
  for (const BackendEntry& e : backendRegistry())
    if (e.deposit) soil_backends.push_back(e.capabilities.name);
  cmd->add_option("--backend", opt->backend,
                  "DEM that deposits (default: the study's soil.deposition.backend). The soil is the study's only if "
                  "its soil.deposition.backend names the same backend")
      ->check(CLI::IsMember(soil_backends));
  cmd->add_option("--soil-dir", opt->soil_dir, "Directory of settled soils (default: $DEMFEM_SOIL_DIR or ./soil)");
  cmd->add_option("--threads", opt->threads,
                  "threads of the built-in deposition (default: the study's /soil/deposition/threads); they are part of "
                  "the soil hash, so another count is another soil file")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--force", opt->force, "Deposit again even if the file exists");
  cmd->add_flag("--quiet", opt->quiet, "No progress output");
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([opt, &json_target] {
    study::Study s = cli::loadCheckedStudy(opt->study_file);
    if (!opt->backend.empty()) {
      s.soil.deposition_backend = opt->backend;
      checkBackends(s);  // the laws of the study in the backend that deposits
    }
    if (opt->threads > 0) s.soil.deposition_threads = opt->threads;
    const std::filesystem::path dir =
        opt->soil_dir.empty() ? adapter::defaultSoilDirectory() : std::filesystem::path(opt->soil_dir);
    const auto file = adapter::settledSoilFile(s, dir);
    const bool text = textOnStdout(json_target);
    if (std::filesystem::exists(file) && !opt->force) {
      const auto soil = adapter::readSettledSoil(file, s);
      if (text) std::cout << "already deposited: ", printSoil(file, soil);
      writeJson(json_target, reportJson(opt->study_file, file, soil, true));
      return;
    }
    DepositCost cost;
    const auto start = std::chrono::steady_clock::now();
    adapter::SettledSoil soil;
    const bool deposited = adapter::depositOnce(
        file, [&] { return soil = depositWith(s.soil.deposition_backend, s, s.soil.deposition_threads, cost, opt->quiet); }, opt->force);
    if (!deposited) {  // another process deposited it while this one waited for the lock
      soil = adapter::readSettledSoil(file, s);
      if (text) std::cout << "already deposited: ", printSoil(file, soil);
      writeJson(json_target, reportJson(opt->study_file, file, soil, true));
      return;
    }
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (text) {
      printSoil(file, soil);
      if (cost.steps > 0) std::cout << "  " << cost.steps << " steps of " << cost.time_step_s << " s";
      if (cost.reload_steps > 0) std::cout << " and " << cost.reload_steps << " reload steps of " << cost.reload_time_step_s << " s";
      std::cout << "  " << wall_s << " s wall\n";
    }
    nlohmann::json report = reportJson(opt->study_file, file, soil, false);
    report["steps"] = cost.steps;
    report["time_step_s"] = cost.time_step_s;
    report["reload_steps"] = cost.reload_steps;
    report["reload_time_step_s"] = cost.reload_time_step_s;
    report["wall_time_s"] = wall_s;
    writeJson(json_target, report);
  });
}

}  // namespace demfem::cli
