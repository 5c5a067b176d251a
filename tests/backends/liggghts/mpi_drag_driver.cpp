// Test driver for the MPI leader/follower scheme: run under `mpirun -np N`, rank 0 drives the
// coupling API, the other ranks follow. Drags the small study's tool across the rank boundary and
// writes, from rank 0, a JSON object with the mean draught force and the bookkeeping checks.
// Usage: liggghts_mpi_drag_driver SEED OUT.json
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/adapter/tool_drive.hpp"
#include "small_study.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iostream>
#include <string>

using namespace demfem;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: " << argv[0] << " SEED OUT.json\n";
    return 2;
  }
  try {
    auto study = liggghts::testing::smallStudy();
    study.soil.deposition_seed = std::stoull(argv[1]);
    study.tools[0].motion.start_z_m = 0.06;  // the z slab boundary of 2 ranks lies at about z = 0.08
    if (!liggghts::isLeaderRank()) {
      liggghts::followLeader(study);
      return 0;
    }
    auto backend = liggghts::makeBackend(study);
    study.tools[0].motion.velocity_m_s = 0.3;
    adapter::insertAndStartDrag(*backend, study, study.tools[0]);
    double draught = 0, worst_split_error = 0;
    const int intervals = 10;
    for (int i = 0; i < intervals; ++i) {
      backend->simulate(0.01);
      const auto mean = backend->nodeForces("tool", adapter::ForceMode::IntervalMean);
      const auto last = backend->nodeForces("tool", adapter::ForceMode::Instantaneous);
      const auto mesh_total = liggghts::meshTotalForce(*backend, "tool");
      for (std::size_t c = 0; c < 3; ++c) {
        double sum = 0;
        for (std::size_t k = c; k < last.size(); k += 3) sum += last[k];
        worst_split_error = std::max(worst_split_error, std::abs(sum - mesh_total[c]));
      }
      for (std::size_t k = 2; k < mean.size(); k += 3) draught -= mean[k];
    }
    double position_sum = 0;
    for (double v : backend->nodePositions("tool")) position_sum += v;
    nlohmann::json out = {{"draught_N", draught / intervals},
                          {"split_error_N", worst_split_error},
                          {"node_position_sum_m", position_sum},
                          {"time_s", backend->time()}};
    backend->shutdown();
    std::ofstream(argv[2]) << out.dump() << '\n';
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  }
}
