// End to end on LIGGGHTS: `demfem-dem --backend liggghts` and `demfem-fem run` as separate processes,
// a small version of studies/quick_liggghts.json (one tool, a few hundred particles, a short drag).
// Between the two processes this test relays the protocol (adapter::Server over a RemoteProxy to
// demfem-dem) and records the node forces the FEM client received, so the client's outputs can be
// checked against the DEM's forces. Every wait is bounded; LIGGGHTS may exit() on an error, which
// the relay reports as a gone server.
#include "demfem/adapter/forwarding_api.hpp"
#include "demfem/adapter/remote_proxy.hpp"
#include "demfem/adapter/server.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"
#include "demfem/protocol/transport.hpp"
#include "demfem/study/study.hpp"
#include "process.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <future>
#include <numeric>

using namespace demfem;
using namespace demfem::testing;

namespace {

// Small, fast variant of studies/quick_liggghts.json (same laws, materials, layers, tool material
// and FEM settings): a 140 x 80 mm bin filled 40 mm deep (about 480 particles), a 120 x 20 mm PMMA
// tool (250 keypoints) inserted 18 mm deep at 300 mm/s and dragged 40 mm at 100 mm/s (400 FEM steps
// of 1 ms).
fs::path smallLiggghtsStudy(const fs::path& dir) {
  nlohmann::json study = shippedStudyJson("quick_liggghts.json");
  study["name"] = "quick_liggghts_small";
  useSmallBin(study);
  useSmallTool(study);
  useShortStroke(study, 40);
  study["dem"]["backend"] = "liggghts";
  return writeStudy(study, dir / "quick_liggghts_small.json");
}

// Forwards every call to the DEM server and records what the FEM client sent and received.
class RecordingRelay final : public adapter::ForwardingApi {
 public:
  explicit RecordingRelay(adapter::CouplingApi& dem) : ForwardingApi(dem) {}

  adapter::NodeArray nodePositions(const std::string& geometry) override {
    auto xyz = inner().nodePositions(geometry);
    if (undeformed.empty()) undeformed = xyz;
    return xyz;
  }
  adapter::NodeArray nodeForces(const std::string& geometry, adapter::ForceMode mode) override {
    auto f = inner().nodeForces(geometry, mode);
    if (mode == adapter::ForceMode::IntervalMean) interval_forces.push_back(f);
    return f;
  }
  void setNodePositions(const std::string& geometry, const adapter::NodeArray& xyz) override {
    inner().setNodePositions(geometry, xyz);
    last_set_positions = xyz;
  }
  // Before the DEM server shuts down: the keypoints it holds are the ones the FEM client last set.
  void shutdown() override {
    if (!shut_down && !last_set_positions.empty()) {
      try {
        positions_at_end = inner().nodePositions(kTool);
      } catch (const std::exception& e) {  // the server must still be shut down; the test reports it
        read_back_error = e.what();
      }
    }
    shut_down = true;
    inner().shutdown();
  }

  static constexpr const char* kTool = "PMMA";  // the tool of studies/quick_liggghts.json
  adapter::NodeArray undeformed, last_set_positions, positions_at_end;
  std::vector<adapter::NodeArray> interval_forces;  // one per coupling cycle, in call order
  std::string read_back_error;
  bool shut_down = false;
};

// z component summed over the keypoints (N, tool frame = bin frame axes).
double totalZ(const adapter::NodeArray& f) {
  double sum = 0;
  for (std::size_t k = 2; k < f.size(); k += 3) sum += f[k];
  return sum;
}

}  // namespace

TEST_CASE("a coupled run of demfem-fem against demfem-dem on LIGGGHTS completes and its sensors follow the DEM forces",
          "[apps][liggghts][physics]") {
  const fs::path dir = freshDir("liggghts-coupled");
  const fs::path study_file = smallLiggghtsStudy(dir);
  // The settled soil is kept in the test's own directory, so every run deposits afresh.
  ::setenv("DEMFEM_SOIL_DIR", (dir / "soil").c_str(), 1);

  const fs::path endpoint_file = dir / "dem.endpoint";
  Process dem({app("demfem-dem"), "--backend", "liggghts", "--study", study_file.string(), "--insecure", "--bind", "tcp://127.0.0.1:*",
               "--endpoint-file", endpoint_file.string(), "--idle-timeout-s", "60", "--connect-timeout-s", "120"},
              dir / "dem");
  // Deposition happens before demfem-dem binds its socket.
  REQUIRE(waitForFile(endpoint_file, dem, 90s));

  // The relay: an adapter::Server in a thread of this process, serving a RemoteProxy to demfem-dem.
  std::promise<std::string> relay_endpoint;
  auto relay_endpoint_ready = relay_endpoint.get_future();
  std::unique_ptr<RecordingRelay> relay;
  std::string relay_error;
  std::thread relay_thread([&] {
    try {
      adapter::RemoteOptions remote;
      remote.endpoint = endpointFrom(endpoint_file);
      remote.timeout = 60s;
      remote.client_name = "liggghts coupled-run test relay";
      adapter::RemoteProxy proxy(remote);
      relay = std::make_unique<RecordingRelay>(proxy);
      protocol::Context context;
      protocol::ServerSocket socket(context, "tcp://127.0.0.1:*", {.insecure_tcp = true});
      relay_endpoint.set_value(socket.endpoint());
      adapter::ServerOptions options;
      options.idle_timeout = 60s;
      adapter::Server server(*relay, options);
      server.serve(socket, 60s);
    } catch (const std::exception& e) {
      relay_error = e.what();
      try {
        relay_endpoint.set_value("");
      } catch (const std::future_error&) {  // already set: the error came while serving
      }
    }
  });
  const std::string relayed = relay_endpoint_ready.get();
  int fem_status = -1;
  std::string fem_err;
  if (!relayed.empty()) {
    Process fem({app("demfem-fem"), "run", study_file.string(), "--connect", relayed, "--output", (dir / "out").string(),
                 "--quiet", "--timeout-s", "60"},
                dir / "fem");
    try {
      fem_status = fem.wait(150s);
    } catch (const std::runtime_error& e) {  // killed after the limit; the relay then times out
      fem_err = e.what();
    }
    fem_err += fem.err();
  }
  relay_thread.join();
  INFO("relay: " << relay_error << "\ndemfem-fem stderr: " << fem_err << "\ndemfem-dem stderr: " << dem.err());
  REQUIRE(relay_error.empty());
  REQUIRE(exitedOk(fem_status));
  CHECK(exitedOk(dem.wait(30s)));  // shut down by the client through the relay

  // The run completed: all outputs final, none marked incomplete.
  const auto sidecar = nlohmann::json::parse(readText(dir / "out" / "sensors.json"));
  CHECK(sidecar["complete"] == true);
  const auto rows = csvRows(dir / "out" / "sensors.csv");
  const study::Study study = study::loadStudy(study_file);
  const auto& tool = study.tools[0];
  // stroke / velocity = 0.4 s of drag in FEM steps of 1 ms.
  REQUIRE(rows.size() == static_cast<std::size_t>(std::llround(tool.motion.stroke_m / tool.motion.velocity_m_s / study.fem.dt_s)));
  REQUIRE(relay->interval_forces.size() > rows.size());  // insertion cycles come first

  // The LIGGGHTS mesh carries the deflection the FEM client set last (read back before shutdown).
  INFO("reading the keypoints back: " << relay->read_back_error);
  REQUIRE(relay->positions_at_end.size() == relay->last_set_positions.size());
  double largest_deflection = 0;
  for (std::size_t v = 0; v < relay->positions_at_end.size(); ++v) {
    // 1e-12 m: positions are sums of the undeformed keypoint and the increments (round-off only).
    CHECK(relay->positions_at_end[v] == Approx(relay->last_set_positions[v]).margin(1e-12));
    largest_deflection = std::max(largest_deflection, std::abs(relay->last_set_positions[v] - relay->undeformed[v]));
  }
  CHECK(largest_deflection > 1e-7);  // the tool really was bent (0.1 um is far above round-off)

  // The drag rows and the forces they were computed from: the last rows.size() interval means.
  const std::size_t first = relay->interval_forces.size() - rows.size();
  const std::size_t n = relay->undeformed.size();
  Eigen::VectorXd mean_force = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
  double mean_draught_N = 0, mean_load_cell_N = 0, mean_deformation_mm = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& f = relay->interval_forces[first + i];
    for (std::size_t v = 0; v < n; ++v) mean_force[static_cast<Eigen::Index>(v)] += f[v] / static_cast<double>(rows.size());
    mean_draught_N += -totalZ(f) / static_cast<double>(rows.size());
    mean_load_cell_N += rows[i][2] / static_cast<double>(rows.size());
    mean_deformation_mm += rows[i][3] / static_cast<double>(rows.size());
  }

  // The soil resists the drag: the DEM's total force on the tool points against travel (-z), and
  // clearly so: 0.05 N is about the weight of 2 particles.
  CHECK(mean_draught_N > 0.05);

  // Quasi-static equilibrium: the tool's first mode (~180 Hz, damping ratio ~0.3 with Table 3's
  // alpha) is far above the drag's time scale, so the mean of the dynamic response over the drag
  // equals the static response to the mean DEM force (the FEM is linear). The load cell is not the
  // whole reaction: the clamp above it is fixed too (a propped cantilever), so the reference is the
  // static solution of the same model, not the total force. What remains is the inertial and
  // damping force averaged over the window, (M dv + C du) / T, and the ~3 ms the response lags the
  // forces at the window's ends: below 1 % of the mean for 400 steps (measured: 0.03 % on the load
  // cell, 0.08 % on the deformation); 2 % leaves margin for the DEM's force spikes at the ends.
  fem::ReducedModel model = fem::reduce(fem::buildFullModel(tool));
  const fem::Sensors sensors(model, tool);
  const std::vector<int> match = fem::matchKeypoints(model, relay->undeformed, 1e-9);
  Eigen::VectorXd load = Eigen::VectorXd::Zero(model.dofCount());
  for (std::size_t k = 0; k < match.size(); ++k)
    for (int c = 0; c < 3; ++c) load[3 * match[k] + c] = mean_force[static_cast<Eigen::Index>(3 * k + static_cast<std::size_t>(c))];
  const fem::StaticSolution quasi_static = fem::solveStatic(model, load);
  const fem::SensorReadings expected = sensors.read(quasi_static.displacement, quasi_static.reaction);
  INFO("mean draught " << mean_draught_N << " N; load cell: coupled mean " << mean_load_cell_N << " N, static "
                       << expected.load_cell_N << " N; deformation: coupled mean " << mean_deformation_mm
                       << " mm, static " << expected.deformation_mm << " mm");
  CHECK(mean_load_cell_N == Approx(expected.load_cell_N).epsilon(0.02));
  CHECK(mean_deformation_mm == Approx(expected.deformation_mm).epsilon(0.02));
  // Loaded against travel, the load cell reads positive and the plate bends backwards (sensors.hpp).
  CHECK(mean_load_cell_N > 0);
  CHECK(mean_deformation_mm > 0);
  fs::remove_all(dir);
}

TEST_CASE("studies/quick_liggghts.json runs through demfem run on both DEM backends", "[apps][liggghts][physics]") {
  // The study file itself (bin, layers, laws, tool; deposition included), with the insertion sped up
  // to 300 mm/s and the run cut to its first 200 FEM steps, so both runs fit the test budget.
  const fs::path dir = freshDir("quick-liggghts-both");
  nlohmann::json study = shippedStudyJson("quick_liggghts.json");
  study["tools"][0]["motion"]["insertion_velocity_mm_s"] = 300;
  const fs::path study_file = writeStudy(study, dir / "quick_liggghts.json");
  ::setenv("DEMFEM_SOIL_DIR", (dir / "soil").c_str(), 1);
  const int steps = 200;
  // Insertion: tip from one largest diameter above the fill to the depth, in whole FEM steps.
  const double insertion_mm = study["soil"]["particles"]["diameter_max_mm"].get<double>() +
                              study["tools"][0]["motion"]["depth_mm"].get<double>();
  const double insertion_s = insertion_mm / 300.0;
  const auto insertion_steps =
      static_cast<std::size_t>(std::ceil(insertion_s / study["fem"]["dt_s"].get<double>() - 1e-9));
  for (const std::string backend : {"builtin", "liggghts"}) {
    INFO("backend " << backend);
    const fs::path out = dir / backend;
    Process run({app("demfem"), "run", study_file.string(), "--backend", backend, "--steps", std::to_string(steps),
                 "--output", out.string(), "--quiet"},
                dir / backend);
    const int status = run.wait(100s);
    INFO("demfem run stderr: " << run.err());
    REQUIRE(exitedOk(status));
    CHECK(nlohmann::json::parse(readText(out / "sensors.json"))["complete"] == false);  // cut by --steps
    const auto rows = csvRows(out / "sensors.csv");
    CHECK(rows.size() == static_cast<std::size_t>(steps) - insertion_steps);
    double largest_force = 0;
    for (const auto& row : rows) {
      REQUIRE(std::isfinite(row[2]));
      largest_force = std::max(largest_force, std::abs(row[2]));
    }
    CHECK(largest_force > 0.1);  // the tool is in the soil: the load cell reads a force
  }
  fs::remove_all(dir);
}
