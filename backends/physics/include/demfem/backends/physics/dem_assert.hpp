// DEMFEM_ASSERT(condition): a debug-only check of an index or an invariant inside the DEM loops
// (docs/architecture.md section 11).
//
// Contract
// - Compiled in when DEMFEM_ASSERTIONS is defined: the Debug and the sanitizer builds
//   (DEMFEM_SANITIZE, scripts/test.sh) define it for every target that links demfem_dem_physics.
//   Elsewhere the condition is not evaluated (it costs nothing in the Release build).
// - A failed check is a bug of the code, not of its input: it prints the condition, file and line
//   to stderr and aborts (bad input is refused with an exception long before the loops run).
#pragma once

#include <cstdio>
#include <cstdlib>

namespace demfem::physics {

[[noreturn]] inline void assertionFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "%s:%d: DEMFEM_ASSERT(%s) failed\n", file, line, condition);
  std::abort();
}

}  // namespace demfem::physics

#if defined(DEMFEM_ASSERTIONS)
#define DEMFEM_ASSERT(condition) \
  ((condition) ? static_cast<void>(0) : ::demfem::physics::assertionFailed(#condition, __FILE__, __LINE__))
#else
#define DEMFEM_ASSERT(condition) static_cast<void>(sizeof(condition))
#endif
