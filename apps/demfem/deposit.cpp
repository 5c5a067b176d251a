#include "commands.hpp"

#include <stdexcept>

namespace demfem::cli {

// Placeholder until its issue lands: says clearly which part is missing.
void addDepositCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("deposit", "Deposit and settle the soil of a study once, for reuse [not built yet: built-in DEM issue]");
  cmd->allow_extras();
  cmd->callback([] { throw std::runtime_error("'demfem deposit' is not built yet (built-in DEM issue)"); });
}

}  // namespace demfem::cli
