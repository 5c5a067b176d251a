// demfem-dem: serves a DEM backend over the demfem protocol. Placeholder until the coupling issue lands.
#include "demfem/cli/cli_support.hpp"

#include <stdexcept>

int main(int argc, char** argv) {
  CLI::App app{"demfem-dem: DEM adapter server of demfem [not built yet: coupling issue]"};
  app.name("demfem-dem");
  app.allow_extras();
  app.callback([] { throw std::runtime_error("demfem-dem is not built yet (coupling issue)"); });
  return demfem::cli::runApp(app, argc, argv);
}
