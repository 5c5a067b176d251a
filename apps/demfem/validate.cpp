#include "commands.hpp"

#include <stdexcept>

namespace demfem::cli {

// Placeholder until its issue lands: says clearly which part is missing.
void addValidateCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("validate", "Check a study file and print its effective values with units [not built yet: foundation issue]");
  cmd->allow_extras();
  cmd->callback([] { throw std::runtime_error("'demfem validate' is not built yet (foundation issue)"); });
}

}  // namespace demfem::cli
