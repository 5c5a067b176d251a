// Keypoint reductions and modal bases kept on disk (docs/fem.md, "Reduction cache"). reduce()
// (model.hpp, Eq 11-15) is a pure function of the full model, modalBasis() (modal.hpp) of the reduced
// model and the step, and their cost dwarfs a short coupled run (about 10 s and 2 s of processor
// time for the paper's PMMA plate against 5 s for the whole quick study's coupling loop), while
// reruns (a calibration's evaluations, a resumed or repeated study, a soil already settled) need
// the same tool again and again.
//
// Contract
// - fullModelHash(model): 16 lowercase hex digits, FNV-1a 64 (study::fnv1a64) of everything reduce()
//   reads (K, M, the keypoint nodes and coordinates, the constraints, the length) and of
//   kFemCacheVersion. Equal models hash equally whatever built them (plate, Gmsh, MatrixMarket).
//   kFemCacheVersion changes whenever reduce()'s or modalBasis()'s arithmetic does, so that no
//   file written by older code is ever read as the current code's result.
// - reductionFile(model, dir) = dir / "reduction-<hash>.bin": the checkpoint container
//   (adapter/checkpoint_file.hpp, kind "fem-reduction") with the hash, the keypoints, the
//   constraints, the length and the lower triangles of K and M.
// - reduceCached(model, dir, progress): the reduced model read from that file when it exists, else
//   reduce(model, progress) written to it (atomically and synced, output_files.hpp) before
//   returning; `dir` is created when missing. Either way the result is bit for bit reduce()'s, so
//   no number of a run depends on whether the cache held its tool. A file that fails any check
//   (container, sizes, the hash it records) throws std::runtime_error naming the file, what failed
//   and that deleting it makes the next run reduce again; a failed write throws
//   adapter::OutputError naming the file. `progress` (may be empty) sees 1.0 after a read.
// - modalBasisCached(full, reduced, dt_s, dir): the same for modalBasis(reduced, dt_s,
//   kQuasiStaticOmegaDt) in dir / "modal-<hash>.bin" (kind "fem-modal-basis": the modes'
//   w^2 and shapes and the lower triangle of R), the hash over the full model's, dt_s and the
//   truncation. Pre: `reduced` is reduce(full).
// - defaultReductionDirectory(): $DEMFEM_FEM_CACHE_DIR when set and not empty, else "fem-cache"
//   (relative to the working directory, as the soil cache's "soil").
#pragma once

#include "demfem/fem/modal.hpp"
#include "demfem/fem/model.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace demfem::fem {

inline constexpr std::uint32_t kFemCacheVersion = 1;

std::string fullModelHash(const FullModel& model);
std::filesystem::path reductionFile(const FullModel& model, const std::filesystem::path& dir);
ReducedModel reduceCached(const FullModel& model, const std::filesystem::path& dir,
                          const std::function<void(double)>& progress = {});
ModalBasis modalBasisCached(const FullModel& full, const ReducedModel& reduced, double dt_s, const std::filesystem::path& dir);
std::filesystem::path defaultReductionDirectory();

}  // namespace demfem::fem
