// demfem: the front end. Starts coupled runs, checks studies, evaluates and compares recordings.
#include "commands.hpp"
#include "demfem/cli/cli_support.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "demfem: two-way coupled DEM-FEM simulation of flexible tools in granular soil.\n"
      "Study files are JSON (studies/*.json); every number carries its unit in its key name."};
  app.name("demfem");
  app.require_subcommand(1);
  demfem::cli::addValidateCommand(app);
  demfem::cli::addRunCommand(app);
  demfem::cli::addDepositCommand(app);
  demfem::cli::addEvaluateCommand(app);
  demfem::cli::addCompareCommand(app);
  demfem::cli::addCalibrateCommand(app);
  demfem::cli::addDiagnoseCommand(app);
  demfem::cli::addCampaignCommand(app);
  demfem::cli::addCptCommand(app);
  demfem::cli::addSoilMotionCommand(app);
  return demfem::cli::runApp(app, argc, argv);
}
