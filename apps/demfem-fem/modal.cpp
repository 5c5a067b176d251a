#include "demfem/cli/cli_support.hpp"

#include <stdexcept>

namespace demfem::cli {

// Placeholder until its issue lands: says clearly which part is missing.
void addFemModalCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("modal", "First natural frequencies of the full and the reduced tool model [not built yet: FEM issue]");
  cmd->allow_extras();
  cmd->callback([] { throw std::runtime_error("'demfem-fem modal' is not built yet (FEM issue)"); });
}

}  // namespace demfem::cli
