#include "demfem/cli/soil_supply.hpp"

#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/cli/cli_support.hpp"
#if DEMFEM_WITH_LIGGGHTS
#include "demfem/backends/liggghts/backend.hpp"
#endif

namespace demfem::cli {

adapter::SettledSoil depositWith(study::DepositionBackend backend, const study::Study& study, int cores,
                                 DepositCost& cost, const std::function<void(const std::string&)>& progress) {
  switch (backend) {
    case study::DepositionBackend::Builtin: {
      builtin::DepositReport report;
      auto soil = builtin::depositSoil(study, cores, report, progress);
      cost = {report.steps, report.time_step_s};
      return soil;
    }
    case study::DepositionBackend::Liggghts:
#if DEMFEM_WITH_LIGGGHTS
      cost = {};
      if (progress) progress("depositing with LIGGGHTS (one insert/pack per layer, one settling)");
      return liggghts::depositSoil(study);
#else
      throw InputError("this demfem was built without LIGGGHTS (DEMFEM_WITH_LIGGGHTS=OFF): cannot deposit with liggghts");
#endif
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

}  // namespace demfem::cli
