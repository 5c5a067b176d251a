#include "commands.hpp"

#include <stdexcept>

namespace demfem::cli {

// Placeholder until its issue lands: says clearly which part is missing.
void addEvaluateCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("evaluate", "Evaluate soil-bin recordings (paper Section 2.3) [not built yet: measured-data issue]");
  cmd->allow_extras();
  cmd->callback([] { throw std::runtime_error("'demfem evaluate' is not built yet (measured-data issue)"); });
}

}  // namespace demfem::cli
