#include "commands.hpp"

#include <stdexcept>

namespace demfem::cli {

// Placeholder until its issue lands: says clearly which part is missing.
void addCompareCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("compare", "Compare measured and simulated runs (paper Sections 3.1, 3.6) [not built yet: measured-data issue]");
  cmd->allow_extras();
  cmd->callback([] { throw std::runtime_error("'demfem compare' is not built yet (measured-data issue)"); });
}

}  // namespace demfem::cli
