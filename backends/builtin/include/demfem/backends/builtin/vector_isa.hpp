// The vector instruction sets the built-in DEM's batch loops and Verlet sweeps are compiled for
// (backends/builtin/src/pair_forces.cpp, wall_forces.cpp and simulation.cpp; docs/builtin-dem.md,
// "Performance design").
//
// Contract
// - Every set gives the same numbers bit for bit: the loops do the same IEEE operations in the same
//   order on each contact or particle whatever the vector width, with no fused multiply-add.
// - The loops use the widest set the CPU runs, or a narrower one if capped. The cap is process-wide
//   and is read at each batch: set it between steps, not while a simulation runs. It exists so
//   that the tests can run every set this CPU has and compare the bits.
#pragma once

namespace demfem::builtin {

enum class VectorIsa { Baseline, Avx2, Avx512 };  // ordered by width

VectorIsa hostVectorIsa();               // the widest this CPU runs (Baseline off x86-64)
VectorIsa vectorIsa();                   // the one the batch loops use: the host's, at most the cap
void capVectorIsa(VectorIsa widest);     // cap (Avx512: no cap)
const char* vectorIsaName(VectorIsa isa);  // "baseline", "avx2", "avx512"

}  // namespace demfem::builtin
