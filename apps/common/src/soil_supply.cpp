#include "demfem/cli/soil_supply.hpp"

#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#if DEMFEM_WITH_LIGGGHTS
#include "demfem/backends/liggghts/backend.hpp"
#endif

#include <iostream>

namespace demfem::cli {

adapter::SettledSoil depositWith(study::DepositionBackend backend, const study::Study& study, int cores,
                                 DepositCost& cost, bool quiet) {
  Progress progress("deposition", !quiet);
  switch (backend) {
    case study::DepositionBackend::Builtin: {
      builtin::DepositReport report;
      auto soil = builtin::depositSoil(study, cores, report, [&](double fraction, const std::string& stage_line) {
        if (!stage_line.empty() && !quiet) std::cerr << "deposition: " << stage_line << std::endl;
        progress.update(fraction);
      });
      progress.finish(std::to_string(soil.particles.size()) + " particles");
      cost = {report.steps, report.time_step_s};
      return soil;
    }
    case study::DepositionBackend::Liggghts: {
#if DEMFEM_WITH_LIGGGHTS
      cost = {};
      if (!quiet) std::cerr << "deposition: with LIGGGHTS (one insert/pack per layer, one settling)" << std::endl;
      auto soil = liggghts::depositSoil(study);
      progress.finish(std::to_string(soil.particles.size()) + " particles");
      return soil;
#else
      throw InputError("this demfem was built without LIGGGHTS (DEMFEM_WITH_LIGGGHTS=OFF): cannot deposit with liggghts");
#endif
    }
  }
  throw std::logic_error("depositWith: unknown deposition backend");
}

void requireSettled(const adapter::SettledSoil& soil, const std::filesystem::path& file, bool allow_unsettled) {
  const std::string reason = adapter::unsettledReason(soil.settling);
  if (reason.empty() || allow_unsettled) return;
  throw InputError("the settled soil " + file.string() + " is not settled: " + reason +
                   ". Raise soil.deposition.settle_kinetic_energy_J and deposit it again (demfem deposit --force), "
                   "or run on it anyway with --allow-unsettled-soil");
}

namespace {

// A soil deposited by the other backend than the one serving is deposited here (this process,
// before the backend is built) when its file is missing; the serving backend deposits its own.
void provideSoil(const study::Study& study, const std::string& backend) {
  const auto file = adapter::settledSoilFile(study, adapter::defaultSoilDirectory());
  const std::string& deposition = study::depositionBackendName(study.soil.deposition_backend);
  if (std::filesystem::exists(file) || deposition == backend) return;
  std::cerr << "depositing the soil with " << deposition << " into " << file.string() << std::endl;
  DepositCost cost;
  adapter::writeSettledSoil(file, depositWith(study.soil.deposition_backend, study, study.dem.threads, cost, false));
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
