// The leader/follower MPI scheme: 2 ranks agree with 1 rank within the DEM's seed-to-seed scatter.
// Runs the driver through mpirun (as root on CI: OpenMPI must be told that is allowed).
#include <catch2/catch.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

nlohmann::json runDriver(int ranks, int seed) {
  const auto out = std::filesystem::temp_directory_path() /
                   ("demfem-liggghts-mpi-" + std::to_string(ranks) + "-" + std::to_string(seed) + ".json");
  std::filesystem::remove(out);
  const std::string command = std::string("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 ") +
                              DEMFEM_MPIEXEC + " -np " + std::to_string(ranks) + " --oversubscribe " +
                              DEMFEM_MPI_DRIVER + " " + std::to_string(seed) + " " + out.string();
  INFO(command);
  REQUIRE(std::system(command.c_str()) == 0);
  std::ifstream in(out);
  nlohmann::json result = nlohmann::json::parse(in);
  std::filesystem::remove(out);
  return result;
}

}  // namespace

TEST_CASE("two MPI ranks reproduce one rank within the seed-to-seed scatter", "[liggghts]") {
  std::vector<double> serial;
  for (int seed : {1, 2, 3}) {
    const auto r = runDriver(1, seed);
    CHECK(r["split_error_N"].get<double>() < 1e-9);
    serial.push_back(r["draught_N"].get<double>());
  }
  double mean = 0, var = 0;
  for (double f : serial) mean += f / 3;
  for (double f : serial) var += (f - mean) * (f - mean) / 2;
  const double scatter = std::sqrt(var);
  REQUIRE(mean > 0);

  const auto parallel = runDriver(2, 1);
  const auto repeat = runDriver(1, 1);
  // Same seed, same rank count: bit-identical (determinism).
  CHECK(repeat["draught_N"].get<double>() == serial[0]);
  // Keypoint split and rank reduction conserve the force the stress mesh sums over the ranks.
  CHECK(parallel["split_error_N"].get<double>() < 1e-9);
  // Rigid motion and merged keypoints are the same whatever the decomposition.
  CHECK(parallel["node_position_sum_m"].get<double>() == Approx(repeat["node_position_sum_m"].get<double>()).margin(1e-9));
  CHECK(parallel["time_s"].get<double>() == repeat["time_s"].get<double>());
  // Different summation order makes the 2-rank run another sample of the same process: within
  // 3 standard deviations of the seed scatter (and at least 5 % of the mean, for a small sample).
  INFO("serial draught " << serial[0] << ", " << serial[1] << ", " << serial[2] << " N; 2 ranks "
                         << parallel["draught_N"].get<double>() << " N");
  CHECK(std::abs(parallel["draught_N"].get<double>() - mean) <= std::max(3 * scatter, 0.05 * mean));
}
