#include "demfem/cli/soil_supply.hpp"

#include "demfem/cli/cli_support.hpp"

namespace demfem::cli {

adapter::SettledSoil depositWith(const std::string& backend, const study::Study& study, int cores, DepositCost& cost, bool quiet) {
  const BackendEntry& entry = findBackend(backend);
  if (!entry.deposit) throw InputError("the " + backend + " backend simulates no particles: it cannot deposit a soil");
  return entry.deposit(study, cores, cost, quiet);
}

void requireSettled(const adapter::SettledSoil& soil, const std::filesystem::path& file, bool allow_unsettled) {
  const std::string message = adapter::unsettledSoilMessage(file, soil.settling);
  if (!message.empty() && !allow_unsettled) throw InputError(message);
}

namespace {

// A soil deposited by the other backend than the one serving is deposited here (this process,
// before the backend is built) when its file is missing; the serving backend deposits its own.
void provideSoil(const study::Study& study, const std::string& backend) {
  const auto file = adapter::settledSoilFile(study, adapter::defaultSoilDirectory());
  const std::string& deposition = study.soil.deposition_backend;
  if (std::filesystem::exists(file) || deposition == backend) return;
  std::cerr << "depositing the soil with " << deposition << " into " << file.string() << std::endl;
  DepositCost cost;
  adapter::depositOnce(file, [&] { return depositWith(study.soil.deposition_backend, study, study.soil.deposition_threads, cost, false); });
}

}  // namespace

std::unique_ptr<adapter::CouplingApi> openSoilBackend(const BackendEntry& backend, const study::Study& study, bool allow_unsettled) {
  provideSoil(study, backend.capabilities.name);
  auto api = backend.make(study, adapter::TestLoad{});
  const auto file = adapter::settledSoilFile(study, adapter::defaultSoilDirectory());
  requireSettled(adapter::readSettledSoil(file, study), file, allow_unsettled);
  return api;
}

}  // namespace demfem::cli
