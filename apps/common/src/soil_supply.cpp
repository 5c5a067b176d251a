#include "demfem/cli/soil_supply.hpp"

#include "demfem/cli/cli_support.hpp"

namespace demfem::cli {

adapter::SettledSoil depositWith(const std::string& backend, const study::Study& study, int cores, DepositCost& cost, bool quiet) {
  const BackendEntry& entry = findBackend(backend);
  if (!entry.deposit) throw InputError("the " + backend + " backend simulates no particles: it cannot deposit a soil");
  return entry.deposit(study, cores, cost, quiet);
}

void requireSettled(const adapter::SettledSoil& soil, const std::filesystem::path& file, bool allow_unsettled) {
  const std::string reason = adapter::unsettledReason(soil.settling);
  if (reason.empty() || allow_unsettled) return;
  throw InputError("the settled soil " + file.string() + " is not settled: " + reason +
                   ". Raise soil.deposition.settle_kinetic_energy_J and deposit it again (demfem deposit --force), "
                   "or run on it anyway with --allow-unsettled-soil");
}

}  // namespace demfem::cli
