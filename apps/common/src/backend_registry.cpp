#include "demfem/cli/backend_registry.hpp"

#include "demfem/backends/builtin/backend.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/backends/physics/time_step.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#if DEMFEM_WITH_LIGGGHTS
#include "demfem/backends/liggghts/backend.hpp"
#endif

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <iostream>

namespace demfem::cli {

namespace {

// Measured on the 2-core development machine; the only place these figures enter the code.
// docs/builtin-dem.md: EDEM laws on the full paper bin, 3.6 M particle-steps/s on 1 thread, 6.3 M on 2.
constexpr double kBuiltinParticleStepsPerS = 3.6e6;
constexpr double kBuiltinExtraThreadGain = 6.3 / 3.6 - 1.0;  // per thread beyond the first
// docs/liggghts-backend.md / README: LIGGGHTS 1.73 M against the built-in's 4.58 M on the same particles.
constexpr double kLiggghtsToBuiltinSpeed = 1.73 / 4.58;

BackendEntry builtinEntry() {
  return {builtin::capabilities(),
          [](const std::optional<study::Study>& study, const adapter::TestLoad&) {
            cli::Progress deposition("deposition", true);  // reports only when the backend deposits
            auto api = builtin::makeBackend(*study, [&deposition](double fraction, const std::string& stage_line) {
              if (!stage_line.empty()) std::cerr << "deposition: " << stage_line << std::endl;
              deposition.update(fraction);
            });
            deposition.finish();
            return api;
          },
          {},
          [](const study::Study& study, int cores, DepositCost& cost, bool quiet) {
            Progress progress("deposition", !quiet);
            builtin::DepositReport report;
            auto soil = builtin::depositSoil(study, cores, report, [&](double fraction, const std::string& stage_line) {
              if (!stage_line.empty() && !quiet) std::cerr << "deposition: " << stage_line << std::endl;
              progress.update(fraction);
            });
            progress.finish(std::to_string(soil.particles.size()) + " particles");
            cost = {report.steps, report.time_step_s, report.reload_steps, report.reload_time_step_s};
            return soil;
          },
          [](const study::Study& study) {
            return DemSpeed{study.dem.threads, kBuiltinParticleStepsPerS * (1.0 + kBuiltinExtraThreadGain * (study.dem.threads - 1))};
          }};
}

#if DEMFEM_WITH_LIGGGHTS
BackendEntry liggghtsEntry() {
  return {liggghts::capabilities(),
          [](const std::optional<study::Study>& study, const adapter::TestLoad&) { return liggghts::makeBackend(*study); },
          [](const study::Study& study) {
            if (liggghts::isLeaderRank()) return false;
            liggghts::followLeader(study);  // non-leader MPI rank: no socket
            return true;
          },
          [](const study::Study& study, int, DepositCost& cost, bool quiet) {
            Progress progress("deposition", !quiet);
            cost = {};
            if (!quiet) std::cerr << "deposition: with LIGGGHTS (one insert/pack per layer, one settling)" << std::endl;
            auto soil = liggghts::depositSoil(study);
            progress.finish(std::to_string(soil.particles.size()) + " particles");
            return soil;
          },
          // One MPI rank unless started by mpirun.
          [](const study::Study&) { return DemSpeed{1, kBuiltinParticleStepsPerS * kLiggghtsToBuiltinSpeed}; }};
}
#endif

BackendEntry testEntry(const std::string& name) {
  return {adapter::testBackendCapabilities(name),
          [name](const std::optional<study::Study>& study, const adapter::TestLoad& load) {
            return adapter::makeTestBackend(name, study ? study->tools : std::vector<study::Tool>{study::Tool{}}, load);
          },
          {},
          {},
          {}};
}

std::vector<BackendEntry> makeRegistry() {
  std::vector<BackendEntry> entries{builtinEntry()};
#if DEMFEM_WITH_LIGGGHTS
  entries.push_back(liggghtsEntry());
#endif
  for (const std::string& name : adapter::testBackendNames()) entries.push_back(testEntry(name));
  return entries;
}

}  // namespace

const std::vector<BackendEntry>& backendRegistry() {
  static const std::vector<BackendEntry> registry = makeRegistry();
  return registry;
}

std::vector<study::BackendCapabilities> backendCapabilities() {
  std::vector<study::BackendCapabilities> out;
  for (const BackendEntry& e : backendRegistry()) out.push_back(e.capabilities);
  return out;
}

const BackendEntry& findBackend(const std::string& name) {
  std::string names;
  for (const BackendEntry& e : backendRegistry()) {
    if (e.capabilities.name == name) return e;
    names += (names.empty() ? "" : ", ") + e.capabilities.name;
  }
  throw InputError("unknown backend '" + name + "' (this build offers " + names + ")");
}

void checkBackends(const study::Study& study) {
  const std::vector<study::Issue> issues = study::backendIssues(study, backendCapabilities());
  if (!issues.empty()) throw study::StudyError(study.source.string(), issues);
}

namespace {

// A DEM step from dem.dt_fraction is known only with the critical step (backends/physics), which
// the study library cannot compute: the same step-count limit as for dem.dt_s, checked here.
void checkDemStepCount(const study::Study& study) {
  if (!study::hasSoil(study.kind) || study.dem.dt_s) return;
  std::int64_t fem_steps = 0;
  for (const auto& tool : study.tools) fem_steps = std::max(fem_steps, study::planToolMotion(study, tool).totalSteps());
  const double simulated_s = static_cast<double>(fem_steps) * study.fem.dt_s;
  const double step_s = physics::demTimeStep(study).step_s;
  if (!(simulated_s / step_s > study::kMaxDemSteps)) return;
  char message[256];
  std::snprintf(message, sizeof message, "gives a DEM step of %.3g s, %.3g DEM steps over the %.3g s the study simulates, more than the limit of %.3g",
                step_s, simulated_s / step_s, simulated_s, study::kMaxDemSteps);
  throw study::StudyError(study.source.string(), {{"/dem/dt_fraction", message}});
}

}  // namespace

study::Study loadCheckedStudy(const std::filesystem::path& file) {
  study::Study study = study::loadStudy(file);
  checkBackends(study);
  checkDemStepCount(study);
  return study;
}

}  // namespace demfem::cli
