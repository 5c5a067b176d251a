// The DEM backends of this build, each with the capabilities it declares next to its factory
// (study/backend_capabilities.hpp) and how to build it: the one place that names them all
// (docs/architecture.md section 14, "How to add a backend"). demfem-dem builds its backend here;
// demfem validate, run and deposit judge a study against these capabilities.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/adapter/test_backends.hpp"
#include "demfem/study/backend_capabilities.hpp"
#include "demfem/study/study.hpp"

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace demfem::cli {

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
