#include "demfem/cli/cli_support.hpp"

#include <stdexcept>

namespace demfem::cli {

// Placeholder until its issue lands: says clearly which part is missing.
void addFemRunCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("run", "Coupled run against a DEM server [not built yet: coupling issue]");
  cmd->allow_extras();
  cmd->callback([] { throw std::runtime_error("'demfem-fem run' is not built yet (coupling issue)"); });
}

}  // namespace demfem::cli
