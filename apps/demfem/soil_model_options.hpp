// Options of the soil-bin model shared by `demfem calibrate` and `demfem diagnose` (calibrate.cpp,
// diagnose.cpp; docs/calibration.md): which force the model records, how its soils are packed, and
// whether a run's stroke ends with the statistics window.
#pragma once

#include "demfem/campaign/model.hpp"
#include "demfem/cli/cli_support.hpp"

#include <CLI/CLI.hpp>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

namespace demfem::cli {

struct SoilModelOptions {
  campaign::SoilForce force = campaign::SoilForce::LoadCell;
  bool shared_packing = true;
  bool full_stroke = false;
  int model_seeds = 1;
  bool allow_unsettled_soil = false;
};

inline void addSoilModelOptions(CLI::App& cmd, SoilModelOptions& o) {
  const std::map<std::string, campaign::SoilForce> forces{{"load-cell", campaign::SoilForce::LoadCell},
                                                          {"draught", campaign::SoilForce::Draught}};
  cmd.add_option("--soil-force", o.force,
                 "Force a soil-bin run records: load-cell (coupled run, the sensor) or draught (rigid tool, DEM only: the "
                 "total force against the travel)")
      ->transform(CLI::CheckedTransformer(forces))
      ->default_str("load-cell");
  const std::map<std::string, bool> packings{{"shared", true}, {"per-soil", false}};
  cmd.add_option("--soil-packing", o.shared_packing,
                 "shared: every soil-bin run drags through the deposition of the given study (one per seed, soils in "
                 "OUT/runs/soil); per-soil: each parameter value deposits its own soil")
      ->transform(CLI::CheckedTransformer(packings))
      ->default_str("shared");
  cmd.add_option("--model-seeds", o.model_seeds,
                 "Deposition seeds each soil-bin case runs at (the study's and the next ones), pooled like measured repeats")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd.add_flag("--full-stroke", o.full_stroke,
               "Run every soil-bin case over the study's whole stroke (default: the stroke ends with the statistics window)");
  addAllowUnsettledSoilFlag(cmd, o.allow_unsettled_soil);
}

// With a shared packing the soil files hold relabelled packings: they live in the run cache
// (OUT/runs/soil), never in a soil directory other commands read. Throws InputError if the
// environment cannot be set.
inline void useSoilDirectory(const SoilModelOptions& o, const std::filesystem::path& cache_dir) {
  if (!o.shared_packing) return;
  if (::setenv("DEMFEM_SOIL_DIR", (cache_dir / "soil").c_str(), 1) != 0)
    throw InputError("cannot set DEMFEM_SOIL_DIR to " + (cache_dir / "soil").string());
}

}  // namespace demfem::cli
