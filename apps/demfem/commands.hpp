// Subcommands of the `demfem` front end, one file each.
#pragma once

#include <CLI/CLI.hpp>

namespace demfem::cli {
void addValidateCommand(CLI::App& app);  // validate.cpp
void addRunCommand(CLI::App& app);       // run.cpp
void addDepositCommand(CLI::App& app);   // deposit.cpp
void addEvaluateCommand(CLI::App& app);  // evaluate.cpp
void addCompareCommand(CLI::App& app);   // compare.cpp
void addCalibrateCommand(CLI::App& app); // calibrate.cpp
void addDiagnoseCommand(CLI::App& app);  // diagnose.cpp
void addCampaignCommand(CLI::App& app);  // campaign.cpp
}  // namespace demfem::cli
