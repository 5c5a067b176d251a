// `demfem validate STUDY...`: checks study files and prints their effective values with units.
#include "commands.hpp"
#include "run_cost.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>

#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <memory>
#include <string>
#include <vector>

namespace demfem::cli {

namespace {

std::string describeCost(const RunCost& c) {
  char text[512];
  std::string out = "# cost (estimated from the measured speeds in docs/builtin-dem.md and docs/fem.md)\n";
  if (c.dem_step_s) {
    std::snprintf(text, sizeof text, "dem_step = %.4g s (critical step %.4g s: ", *c.dem_step_s, c.dem_critical_step_s);
    out += text + c.dem_step_why + ")\n";
    if (c.rolling_regularisation_step_s) {
      std::snprintf(text, sizeof text, "rolling_regularisation_step = %.4g s (the edem-standard rolling law's spin scale: %s)\n",
                    *c.rolling_regularisation_step_s,
                    *c.dem_step_s <= *c.rolling_regularisation_step_s ? "the DEM step is not above it, so the law is that of every shorter step"
                                                                       : "the DEM step is above it, so the law changes with the DEM step");
      out += text;
    }
    std::snprintf(text, sizeof text, "dem_steps = %lld\nparticles = %zu (at most: the packing the deposition inserts)\n",
                  static_cast<long long>(c.dem_steps), c.particles);
    out += text;
  }
  std::snprintf(text, sizeof text, "fem_steps = %lld (%.4g s simulated)\nkeypoints = %d\nwall_time = %.0f s (DEM %.0f s on %d core(s), FEM %.0f s; deposition not included)\n",
                static_cast<long long>(c.fem_steps), c.simulated_s, c.keypoints, c.wallSeconds(), c.dem_wall_s, c.threads, c.fem_wall_s);
  return out + text;
}

nlohmann::json costJson(const RunCost& c) {
  return {{"dem_step_s", c.dem_step_s ? nlohmann::json(*c.dem_step_s) : nlohmann::json(nullptr)},
          {"dem_critical_step_s", c.dem_step_s ? nlohmann::json(c.dem_critical_step_s) : nlohmann::json(nullptr)},
          {"dem_step_reason", c.dem_step_s ? nlohmann::json(c.dem_step_why) : nlohmann::json(nullptr)},
          {"rolling_regularisation_step_s",
           c.rolling_regularisation_step_s ? nlohmann::json(*c.rolling_regularisation_step_s) : nlohmann::json(nullptr)},
          {"dem_steps", c.dem_steps},
          {"fem_steps", c.fem_steps},
          {"simulated_s", c.simulated_s},
          {"particles_at_most", c.particles},
          {"keypoints", c.keypoints},
          {"threads", c.threads},
          {"dem_wall_time_s", c.dem_wall_s},
          {"fem_wall_time_s", c.fem_wall_s},
          {"wall_time_s", c.wallSeconds()}};
}

// The study's deposited soil in the soil directory ($DEMFEM_SOIL_DIR or ./soil), if there is one:
// its figures as a run records them (adapter::soilRecordJson), among them the bulk density reached
// and the one stated (soil.deposition.bulk_density_kg_m3); null if not deposited yet.
nlohmann::json depositedSoil(const study::Study& s, std::string& text) {
  const auto file = adapter::settledSoilFile(s, adapter::defaultSoilDirectory());
  if (!std::filesystem::exists(file)) {
    text = "soil_file = " + file.string() + " (not deposited yet)\n";
    return nullptr;
  }
  adapter::SettledSoil soil;
  try {
    soil = adapter::readSettledSoil(file, s);
  } catch (const std::runtime_error& e) {
    text = "soil_file = " + file.string() + " (refused: " + e.what() + ")\n";
    return {{"file", file.string()}, {"refused", e.what()}};
  }
  const auto& f = soil.settling;
  char target[160] = " (plain gravity pour)";
  if (f.target_bulk_density_kg_m3 > 0)
    std::snprintf(target, sizeof target, " (stated %.1f kg/m3, poured with the inter-particle friction x %.3f)",
                  f.target_bulk_density_kg_m3, f.pour_friction_scale);
  char line[1024];
  std::snprintf(line, sizeof line,
                "soil_file = %s\nsoil_particles = %zu\nsoil_packing_fraction = %.4f\nsoil_bulk_density = %.1f kg/m3%s\n"
                "soil_coordination_number = %.3f\n",
                file.string().c_str(), soil.particles.size(), f.packing_fraction, f.bulk_density_kg_m3, target,
                f.coordination_number);
  text = line;
  return nlohmann::json::parse(adapter::soilRecordJson(soil, file, adapter::settledSoilChecksum(file)));
}

}  // namespace

void addValidateCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "validate",
      "Check study files (type, unit, range and cross-field rules of every key; docs/study-file.md) and print "
      "every effective value with its unit, defaults included, and the run's estimated cost (DEM step, DEM and FEM "
      "steps, particles, wall time). Every problem is reported as "
      "'FILE: JSON-PATH: MESSAGE'; exit code 2 if any file is invalid.");
  auto files = std::make_shared<std::vector<std::string>>();
  cmd->add_option("STUDY", *files, "Study files (JSON)")->required()->check(CLI::ExistingFile);
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([files, &json_target] {
    nlohmann::json report{{"studies", nlohmann::json::array()}};
    std::size_t invalid = 0;
    const bool text = json_target != "-";  // stdout carries the JSON document instead
    for (const std::string& file : *files) {
      try {
        const study::Study s = cli::loadCheckedStudy(file);
        const std::string hash = study::hasSoil(s.kind) ? study::soilHash(s) : std::string();
        const RunCost cost = estimateRunCost(s);
        std::string soil_text;
        const nlohmann::json soil = hash.empty() ? nlohmann::json() : depositedSoil(s, soil_text);
        if (text) {
          std::cout << "# " << file << ": valid\n" << study::describe(s);
          if (!hash.empty()) std::cout << "soil_hash = " << hash << '\n' << soil_text;
          std::cout << describeCost(cost) << '\n';
        }
        nlohmann::json entry{{"file", study::validUtf8(file)}, {"valid", true}, {"effective", study::toJson(s)}, {"cost", costJson(cost)}};
        if (!hash.empty()) entry["soil_hash"] = hash, entry["soil"] = soil;
        report["studies"].push_back(entry);
      } catch (const study::StudyError& e) {
        ++invalid;
        std::cerr << e.what() << '\n';
        nlohmann::json problems = nlohmann::json::array();
        for (const study::Issue& issue : e.issues()) problems.push_back({{"path", issue.path}, {"message", issue.message}});
        report["studies"].push_back({{"file", e.file()}, {"valid", false}, {"issues", problems}});
      }
    }
    writeJson(json_target, report);
    if (invalid > 0)
      throw InputError(std::to_string(invalid) + " of " + std::to_string(files->size()) + " study file(s) invalid");
  });
}

}  // namespace demfem::cli
