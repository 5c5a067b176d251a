#include "demfem/cli/backend_registry.hpp"

#include "demfem/backends/builtin/backend.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#if DEMFEM_WITH_LIGGGHTS
#include "demfem/backends/liggghts/backend.hpp"
#endif

#include <iostream>

namespace demfem::cli {

namespace {

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
          {}};
}

#if DEMFEM_WITH_LIGGGHTS
BackendEntry liggghtsEntry() {
  return {liggghts::capabilities(),
          [](const std::optional<study::Study>& study, const adapter::TestLoad&) { return liggghts::makeBackend(*study); },
          [](const study::Study& study) {
            if (liggghts::isLeaderRank()) return false;
            liggghts::followLeader(study);  // non-leader MPI rank: no socket
            return true;
          }};
}
#endif

BackendEntry testEntry(const std::string& name) {
  return {adapter::testBackendCapabilities(name),
          [name](const std::optional<study::Study>& study, const adapter::TestLoad& load) {
            return adapter::makeTestBackend(name, study ? study->tools : std::vector<study::Tool>{study::Tool{}}, load);
          },
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

study::Study loadCheckedStudy(const std::filesystem::path& file) {
  study::Study study = study::loadStudy(file);
  checkBackends(study);
  return study;
}

}  // namespace demfem::cli
