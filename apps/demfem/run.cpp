#include "commands.hpp"

#include <stdexcept>

namespace demfem::cli {

// Placeholder until its issue lands: says clearly which part is missing.
void addRunCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("run", "Run a coupled study: starts demfem-dem and demfem-fem [not built yet: coupling issue]");
  cmd->allow_extras();
  cmd->callback([] { throw std::runtime_error("'demfem run' is not built yet (coupling issue)"); });
}

}  // namespace demfem::cli
