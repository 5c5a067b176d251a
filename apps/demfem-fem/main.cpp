// demfem-fem: the FEM client. Meshes the tool, reduces it to the keypoints and drives a DEM server.
#include "demfem/cli/cli_support.hpp"

namespace demfem::cli {
void addFemModalCommand(CLI::App& app);       // modal.cpp
void addFemStaticCommand(CLI::App& app);      // static.cpp
void addFemWeightDropCommand(CLI::App& app);  // weight_drop.cpp
void addFemRunCommand(CLI::App& app);         // run.cpp
}  // namespace demfem::cli

int main(int argc, char** argv) {
  CLI::App app{"demfem-fem: FEM client of demfem (tool mesh, keypoint substructuring, Eq (5)-(10))."};
  app.name("demfem-fem");
  app.require_subcommand(1);
  demfem::cli::addFemModalCommand(app);
  demfem::cli::addFemStaticCommand(app);
  demfem::cli::addFemWeightDropCommand(app);
  demfem::cli::addFemRunCommand(app);
  return demfem::cli::runApp(app, argc, argv);
}
