// Options of the soil-bin model shared by `demfem calibrate` and `demfem diagnose` (calibrate.cpp,
// diagnose.cpp; docs/calibration.md): which force the model records, and whether a run's stroke
// ends with the statistics window.
#pragma once

#include "demfem/campaign/model.hpp"

#include <CLI/CLI.hpp>

#include <map>
#include <string>

namespace demfem::cli {

inline void addSoilModelOptions(CLI::App& cmd, campaign::SoilForce& force, bool& full_stroke) {
  const std::map<std::string, campaign::SoilForce> words{{"load-cell", campaign::SoilForce::LoadCell},
                                                         {"draught", campaign::SoilForce::Draught}};
  cmd.add_option("--soil-force", force,
                 "Force a soil-bin run records: load-cell (coupled run, the sensor) or draught (rigid tool, DEM only: the "
                 "total force against the travel)")
      ->transform(CLI::CheckedTransformer(words))
      ->default_str("load-cell");
  cmd.add_flag("--full-stroke", full_stroke,
               "Run every soil-bin case over the study's whole stroke (default: the stroke ends with the statistics window)");
}

}  // namespace demfem::cli
