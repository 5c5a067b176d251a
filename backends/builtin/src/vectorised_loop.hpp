// Private to the built-in DEM: how its batch loops over contacts (pair_forces.cpp, wall_forces.cpp)
// and its Verlet sweeps over particles (simulation.cpp) are compiled (docs/builtin-dem.md,
// "Performance design"). A batch loop is an always-inline
// lambda run by runVectorised, which compiles it anew for each vector instruction set and runs the
// one vectorIsa() names; its iterations are marked independent so that GCC vectorises it.
#pragma once

#include "demfem/backends/builtin/vector_isa.hpp"

namespace demfem::builtin {

// A loop whose iterations are independent (no store reaches another iteration's loads). GCC is
// told so; clang's vectoriser, told the same, still refuses these loops and warns each time, so it
// is left to its own analysis (only the sanitizer build uses clang).
#if defined(__clang__)
#define DEMFEM_INDEPENDENT_ITERATIONS
#else
#define DEMFEM_INDEPENDENT_ITERATIONS _Pragma("GCC ivdep")
#endif
#define DEMFEM_INLINE __attribute__((always_inline))

namespace detail {
// runVectorised(f) runs f() compiled for vectorIsa(): f is an always-inline lambda, so its loops
// are compiled anew inside each runner. (Function clones of the batch loops would do the same, but
// clang does not clone templates.)
#if defined(__x86_64__)
template <class F>
[[gnu::target("avx512f")]] void runAvx512(const F& f) {
  f();
}
template <class F>
[[gnu::target("avx2")]] void runAvx2(const F& f) {
  f();
}
#endif
}  // namespace detail

template <class F>
void runVectorised(const F& f) {
  switch (vectorIsa()) {
#if defined(__x86_64__)
    case VectorIsa::Avx512: detail::runAvx512(f); return;
    case VectorIsa::Avx2: detail::runAvx2(f); return;
#else
    case VectorIsa::Avx512:
    case VectorIsa::Avx2:
#endif
    case VectorIsa::Baseline: f(); return;
  }
}

}  // namespace demfem::builtin
