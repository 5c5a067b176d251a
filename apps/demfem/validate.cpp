// `demfem validate STUDY...`: checks study files and prints their effective values with units.
#include "commands.hpp"
#include "run_cost.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>

#include <iostream>
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
        if (text) {
          std::cout << "# " << file << ": valid\n" << study::describe(s);
          if (!hash.empty()) std::cout << "soil_hash = " << hash << '\n';
          std::cout << describeCost(cost) << '\n';
        }
        nlohmann::json entry{{"file", study::validUtf8(file)}, {"valid", true}, {"effective", study::toJson(s)}, {"cost", costJson(cost)}};
        if (!hash.empty()) entry["soil_hash"] = hash;
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
