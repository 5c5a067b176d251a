// Subcommands of the `demfem` front end, one file each.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace demfem::cli {
void addValidateCommand(CLI::App& app);  // validate.cpp
void addRunCommand(CLI::App& app);       // run.cpp
void addDepositCommand(CLI::App& app);   // deposit.cpp
void addEvaluateCommand(CLI::App& app);  // evaluate.cpp
void addCompareCommand(CLI::App& app);   // compare.cpp
void addCalibrateCommand(CLI::App& app); // calibrate.cpp
void addDiagnoseCommand(CLI::App& app);  // diagnose.cpp
void addCampaignCommand(CLI::App& app);  // campaign.cpp
void addCptCommand(CLI::App& app);       // cpt.cpp
void addSoilMotionCommand(CLI::App& app); // soil_motion.cpp

// Cone penetration of `demfem cpt` and of `demfem run` on a cone-penetration study (cpt.cpp).
struct CptOptions {
  std::string output_dir = "out/cpt";
  std::vector<std::string> measured;
  double depth_step_mm = 1.0;
  std::string backend;
  std::string packing;  // study whose deposition every study's soil holds (empty: each its own)
  int threads = 0;
  bool allow_unsettled_soil = false;
  bool no_plots = false;
  bool quiet = false;
  std::string gnuplot = "gnuplot";
};
void runConePenetration(const std::vector<std::string>& study_files, const CptOptions& options, const std::string& json_target);
}  // namespace demfem::cli
