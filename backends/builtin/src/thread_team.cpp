// The system call behind the thread team's wait policy (thread_team.hpp).
#include "demfem/backends/builtin/thread_team.hpp"

#if defined(__linux__)
#include <sys/resource.h>
#endif

namespace demfem::builtin {

long involuntaryContextSwitches() {
#if defined(__linux__)
  rusage usage{};
  if (getrusage(RUSAGE_THREAD, &usage) == 0) return usage.ru_nivcsw;
#endif
  return 0;
}

}  // namespace demfem::builtin
