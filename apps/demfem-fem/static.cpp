#include "demfem/cli/cli_support.hpp"

#include <stdexcept>

namespace demfem::cli {

// Placeholder until its issue lands: says clearly which part is missing.
void addFemStaticCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("static", "Static tip or distributed load: deflection and reactions [not built yet: FEM issue]");
  cmd->allow_extras();
  cmd->callback([] { throw std::runtime_error("'demfem-fem static' is not built yet (FEM issue)"); });
}

}  // namespace demfem::cli
