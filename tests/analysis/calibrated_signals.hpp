// Test helper: the columns of a calibrated synthetic weight-drop recording (synthetic.hpp).
#pragma once

#include "demfem/analysis/synthetic.hpp"

#include <vector>

namespace demfem::analysis::test {

struct Signals {
  std::vector<double> t, force, deformation;
};

inline Signals calibratedSignals(const WeightDropTruth& truth) {
  const SyntheticRecording rec = makeWeightDropRecording(truth, RecordingFormat::Calibrated);
  return {rec.columns[0], rec.columns[1], rec.columns[2]};
}

}  // namespace demfem::analysis::test
