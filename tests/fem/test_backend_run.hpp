// The coupled driver run on an analytic test backend (adapter/test_backends.hpp) and its sensors.csv
// read back: the set-up the coupled-driver and modal-integrator tests share.
#pragma once

#include "demfem/adapter/test_backends.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/study/study.hpp"
#include "demfem/study/tool_motion.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace demfem::fem::testing {

// Runs the driver on test backend `backend` under `load` for the insertion and `drag_steps` drag
// steps, writing its outputs to `out`.
inline void runOnTestBackend(const study::Study& study, const std::string& backend, const adapter::TestLoad& load,
                             const std::filesystem::path& out, int drag_steps) {
  auto dem = adapter::makeTestBackend(backend, study.tools, load);
  CoupledRunOptions options;
  options.output_dir = out;
  options.max_steps = study::planToolMotion(study, study.tools[0]).insertion_steps + drag_steps;
  CoupledDriver(study, options).run(*dem);
}

// A run's sensors.csv: its header line and the columns force_N and deformation_mm (the third and
// fourth); '#' lines skipped.
struct SensorColumns {
  std::string header;
  std::vector<double> force, deformation;
};

inline SensorColumns readSensorColumns(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  SensorColumns c;
  std::getline(in, c.header);
  std::string line;
  while (std::getline(in, line)) {
    if (line[0] == '#') continue;
    std::vector<double> v;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, ',');) v.push_back(std::stod(cell));
    c.force.push_back(v.at(2));
    c.deformation.push_back(v.at(3));
  }
  return c;
}

}  // namespace demfem::fem::testing
