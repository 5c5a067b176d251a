// The DEM backends of this build, each with the capabilities it declares next to its factory
// (study/backend_capabilities.hpp), how to build it, how it deposits a soil and how fast it runs:
// the one place that names them all (docs/architecture.md section 14, "How to add a backend").
// demfem-dem builds its backend here; demfem validate, run and deposit judge a study against these
// capabilities, deposit with the backend soil.deposition.backend names (soil_supply.hpp) and
// estimate a run's cost from its backend's speed (apps/demfem/run_cost.hpp).
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/adapter/test_backends.hpp"
#include "demfem/study/backend_capabilities.hpp"
#include "demfem/study/study.hpp"

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace demfem::cli {

struct DepositCost {
  long steps = 0;          // DEM steps (0 where the backend does not report them)
  double time_step_s = 0;  // deposition step (0 where the backend does not report it)
  long reload_steps = 0;   // the built-in reload phase's steps, at the run's step reload_time_step_s
  double reload_time_step_s = 0;
};

// The measured DEM speed of a run: the threads (or MPI ranks) it uses and the particle-steps per
// second of wall time it reaches on them (docs/builtin-dem.md, docs/liggghts-backend.md).
struct DemSpeed {
  int threads = 1;
  double particle_steps_per_s = 0;
};

struct BackendEntry {
  study::BackendCapabilities capabilities;
  // Builds the backend. Soil backends need the study (the caller checks); test backends take its
  // tools, or one default plate tool without a study, and `load`.
  std::function<std::unique_ptr<adapter::CouplingApi>(const std::optional<study::Study>& study,
                                                      const adapter::TestLoad& load)>
      make;
  // Backends run on several MPI ranks: true on a rank that does not serve (it has run its share of
  // the simulation when this returns). Empty: every process serves.
  std::function<bool(const study::Study& study)> follow;
  // Soil backends: deposits the study's soil on `cores` threads or ranks and returns it (with its
  // settling figures, not written), reporting progress with time left and each stage's summary on
  // standard error unless `quiet`. Empty for a backend that simulates no particles.
  std::function<adapter::SettledSoil(const study::Study& study, int cores, DepositCost& cost, bool quiet)> deposit;
  // Soil backends: the speed a run of `study` reaches. Empty for a backend that simulates no particles.
  std::function<DemSpeed(const study::Study& study)> speed;
};

// Every backend of this build, soil backends first.
const std::vector<BackendEntry>& backendRegistry();
std::vector<study::BackendCapabilities> backendCapabilities();

// The entry named `name`; throws InputError listing the names of this build.
const BackendEntry& findBackend(const std::string& name);

// Throws study::StudyError (file: the study's source) when the study names a backend this build
// lacks or a contact law its backends do not implement (study::backendIssues).
void checkBackends(const study::Study& study);

// study::loadStudy() and checkBackends(): the study a command may run.
study::Study loadCheckedStudy(const std::filesystem::path& file);

}  // namespace demfem::cli
