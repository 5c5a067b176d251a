// End-to-end tests of demfem-dem + demfem-fem as separate processes over tcp://127.0.0.1 (loopback,
// free ports chosen by the server). Every wait is bounded.
#include "demfem/adapter/test_backends.hpp"
#include "demfem/fem/integrator.hpp"
#include "demfem/fem/modal.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"
#include "demfem/study/study.hpp"
#include "process.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

using namespace demfem;
using namespace demfem::testing;

namespace {

// Load of the harmonic test backend used below (adapter/test_backends.hpp).
constexpr double kForceN = -5.0, kFrequencyHz = 40.0;

struct Server {
  Server(const fs::path& dir, const std::string& name, std::vector<std::string> extra)
      : endpoint_file(dir / (name + ".endpoint")),
        process([&] {
          std::vector<std::string> args{app("demfem-dem"), "--bind", "tcp://127.0.0.1:*", "--endpoint-file",
                                        endpoint_file.string(), "--idle-timeout-s", "20", "--connect-timeout-s", "60"};
          // Loopback tcp without keys must be asked for (docs/protocol.md "Sockets and transports").
          if (std::find(extra.begin(), extra.end(), "--curve-keys") == extra.end()) args.push_back("--insecure");
          args.insert(args.end(), extra.begin(), extra.end());
          return args;
        }(), dir / name) {
    if (!waitForFile(endpoint_file, process, 20s)) FAIL("demfem-dem did not start: " << process.err());
    endpoint = endpointFrom(endpoint_file);
  }
  fs::path endpoint_file;
  Process process;
  std::string endpoint;
};

std::vector<std::string> harmonicArgs(const fs::path& study) {
  return {"--backend", "harmonic", "--study", study.string(), "--test-force-N", std::to_string(kForceN),
          "--test-frequency-Hz", std::to_string(kFrequencyHz)};
}

// The DEM server keeps the checkpoints its client names in OUT/checkpoint, as `demfem run` has it.
std::vector<std::string> withCheckpoints(std::vector<std::string> args, const fs::path& out) {
  args.insert(args.end(), {"--checkpoint-dir", (out / "checkpoint").string()});
  return args;
}

std::vector<std::string> femArgs(const fs::path& study, const std::string& endpoint, const fs::path& out,
                                 std::vector<std::string> extra) {
  std::vector<std::string> args{app("demfem-fem"), "run", study.string(), "--connect", endpoint, "--output", out.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

// The FEM alone (fem/ API, no coupling, no processes) with the same load: the harmonic test backend
// object in this process supplies the forces (its closed form is checked against quadrature in
// tests/adapter/test_backends_test.cpp). Sensor readings after each of the last `rows` of
// `total_steps` steps; the load of each step is the mean over the interval before it.
std::vector<fem::SensorReadings> femAloneHistory(const fs::path& study_file, int total_steps, std::size_t rows) {
  const study::Study study = study::loadStudy(study_file);
  const auto& tool = study.tools[0];
  const fem::ReducedModel model = fem::reduce(fem::buildFullModel(tool));
  // The study's integrator (fem.integration), as the FEM client builds it.
  const auto integrator_ptr = fem::makeIntegrator(model, study.fem.dt_s, {tool.fem.alpha_s, tool.fem.beta_per_s}, study.fem.integration);
  fem::TimeIntegrator& integrator = *integrator_ptr;
  const fem::Sensors sensors(model, tool);
  adapter::TestLoad load;
  load.force_N = kForceN;
  load.frequency_Hz = kFrequencyHz;
  const auto harmonic = adapter::makeTestBackend("harmonic", study.tools, load);
  const std::vector<int> match = fem::matchKeypoints(model, harmonic->nodePositions(tool.name), 1e-9);
  const auto toModel = [&](const adapter::NodeArray& f) {
    Eigen::VectorXd v(model.dofCount());
    for (std::size_t i = 0; i < match.size(); ++i)
      for (int c = 0; c < 3; ++c) v[3 * match[i] + c] = f[3 * i + c];
    return v;
  };
  integrator.start(toModel(harmonic->nodeForces(tool.name, adapter::ForceMode::Instantaneous)));
  std::vector<fem::SensorReadings> history;
  for (int i = 0; i < total_steps; ++i) {
    const auto& u = integrator.step(toModel(harmonic->nodeForces(tool.name)));
    harmonic->simulate(study.fem.dt_s);
    if (static_cast<std::size_t>(total_steps - i) <= rows) history.push_back(sensors.read(u, integrator.reactions()));
  }
  return history;
}

// Runs demfem-fem for `total_steps` against the server started by `server_args` (which must write
// its endpoint to ENDPOINT_FILE, substituted), and checks its sensor history against the FEM alone
// to `tolerance` relative to each column's largest value.
void checkAgainstFemAlone(const fs::path& dir, const fs::path& study_file, std::vector<std::string> server_args,
                          double tolerance) {
  const int total_steps = 160;
  const fs::path endpoint_file = dir / "server.endpoint";
  for (auto& a : server_args)
    if (a == "ENDPOINT_FILE") a = endpoint_file.string();
  {
    Process server(server_args, dir / "server");
    REQUIRE(waitForFile(endpoint_file, server, 20s));
    Process fem(femArgs(study_file, endpointFrom(endpoint_file), dir / "out", {"--steps", std::to_string(total_steps)}), dir / "fem");
    REQUIRE(exitedOk(fem.wait(120s)));
    CHECK(exitedOk(server.wait(20s)));  // shut down by the client
  }
  const auto rows = csvRows(dir / "out" / "sensors.csv");
  REQUIRE(rows.size() > 10);  // the drag phase (after the insertion steps) was recorded
  const auto reference = femAloneHistory(study_file, total_steps, rows.size());
  REQUIRE(reference.size() == rows.size());
  double force_scale = 0, deformation_scale = 0, tilt_scale = 0;
  for (const auto& r : reference) {
    force_scale = std::max(force_scale, std::abs(r.load_cell_N));
    deformation_scale = std::max(deformation_scale, std::abs(r.deformation_mm));
    tilt_scale = std::max(tilt_scale, std::abs(r.tip_tilt_deg));
  }
  REQUIRE(force_scale > 0.1);  // the load reached the load cell: the comparison is not vacuous
  const double dt = study::loadStudy(study_file).fem.dt_s;
  double worst_force = 0, worst_deformation = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    worst_force = std::max(worst_force, std::abs(rows[i][2] - reference[i].load_cell_N));
    worst_deformation = std::max(worst_deformation, std::abs(rows[i][3] - reference[i].deformation_mm));
  }
  INFO("largest differences: force " << worst_force << " N of " << force_scale << " N, deformation " << worst_deformation
                                     << " mm of " << deformation_scale << " mm");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    CHECK(rows[i][0] == Approx(static_cast<double>(i + 1) * dt).margin(1e-12));
    CHECK(std::abs(rows[i][2] - reference[i].load_cell_N) <= tolerance * force_scale);
    CHECK(std::abs(rows[i][3] - reference[i].deformation_mm) <= tolerance * deformation_scale);
    CHECK(std::abs(rows[i][4] - reference[i].tip_tilt_deg) <= tolerance * tilt_scale);
  }
  // Cut by --steps: whole rows, but not the whole study, and the sidecar says so.
  const auto sidecar = nlohmann::json::parse(readText(dir / "out" / "sensors.json"));
  CHECK(sidecar["complete"] == false);
  CHECK_THAT(sidecar["incomplete_reason"].get<std::string>(), Catch::StartsWith("stopped after 160 of "));
  CHECK(sidecar["steps"] == total_steps);
  CHECK(fs::file_size(dir / "out" / "keypoint_displacements.f64") == rows.size() * (1 + 3 * 250) * sizeof(double));
}

}  // namespace

TEST_CASE("coupled run against the harmonic backend over tcp equals the FEM alone with the same load", "[apps][physics]") {
  const fs::path dir = freshDir("harmonic-tcp");
  const fs::path study_file = fastQuickStudy(dir);
  std::vector<std::string> server{app("demfem-dem"), "--insecure", "--bind", "tcp://127.0.0.1:*", "--endpoint-file", "ENDPOINT_FILE"};
  for (const auto& a : harmonicArgs(study_file)) server.push_back(a);
  // 1e-12: the arrays travel bit-exact, so the coupled run must reproduce the FEM alone to rounding.
  checkAgainstFemAlone(dir, study_file, server, 1e-12);
  fs::remove_all(dir);
}

TEST_CASE("the Python adapter example serves demfem-fem and matches the FEM alone", "[apps][physics]") {
  const fs::path dir = freshDir("python-adapter");
  const fs::path study_file = fastQuickStudy(dir);
  checkAgainstFemAlone(dir, study_file,
                       {"/usr/bin/python3", (sourceDir() / "examples" / "python_adapter" / "harmonic_server.py").string(),
                        "--study", study_file.string(), "--bind", "tcp://127.0.0.1:*", "--endpoint-file", "ENDPOINT_FILE",
                        "--force-N", std::to_string(kForceN), "--frequency-Hz", std::to_string(kFrequencyHz)},
                       // numpy's sin may differ from libm's in the last bit, and the load-cell
                       // reaction recursion (Eq 10, a neutral period-3 mode) keeps such differences:
                       // measured 2.5e-12 relative after 160 steps; 1e-9 leaves margin, still far
                       // below any physical effect.
                       1e-9);
  fs::remove_all(dir);
}

TEST_CASE("killing demfem-dem mid-run stops demfem-fem within its timeout, CSV marked incomplete", "[apps]") {
  const fs::path dir = freshDir("kill-dem");
  const fs::path study_file = fastQuickStudy(dir);
  Server dem(dir, "dem", harmonicArgs(study_file));
  Process fem(femArgs(study_file, dem.endpoint, dir / "out", {"--timeout-s", "1", "--quiet"}), dir / "fem");
  // Wait until the drag phase has started writing rows, then kill the DEM server.
  const fs::path partial = dir / "out" / "sensors.csv.partial";
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (!(fs::exists(partial) && fs::file_size(partial) > 2000) && std::chrono::steady_clock::now() < deadline && !fem.exited())
    std::this_thread::sleep_for(10ms);
  REQUIRE_FALSE(fem.exited());
  dem.process.signal(SIGKILL);
  const auto killed = std::chrono::steady_clock::now();
  const int status = fem.wait(30s);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  CHECK_FALSE(exitedOk(status));
  CHECK(seconds < 1.0 + 4.0);  // the 1 s timeout plus process teardown
  // Seen as the closed connection (at once), or as no reply within the timeout.
  CHECK_THAT(fem.err(), Catch::Contains("DEM server") && (Catch::Contains("closed the connection") || Catch::Contains("gone")));
  const std::string csv = readText(dir / "out" / "sensors.csv");
  CHECK(csv.find("\n# incomplete: ") != std::string::npos);
  CHECK(nlohmann::json::parse(readText(dir / "out" / "sensors.json"))["complete"] == false);
  fs::remove_all(dir);
}

TEST_CASE("demfem-dem refuses tcp without CurveZMQ keys, naming the ways out", "[apps]") {
  const fs::path dir = freshDir("tcp-no-keys");
  Process dem({app("demfem-dem"), "--backend", "harmonic", "--bind", "tcp://127.0.0.1:*", "--connect-timeout-s", "1"},
              dir / "dem");
  CHECK_FALSE(exitedOk(dem.wait(10s)));
  CHECK_THAT(dem.err(), Catch::Contains("--curve-keys") && Catch::Contains("ipc://") && Catch::Contains("--insecure"));
  fs::remove_all(dir);
}

TEST_CASE("a client with a wrong CurveZMQ key is refused by demfem-dem", "[apps]") {
  const fs::path dir = freshDir("curve");
  const fs::path study_file = fastQuickStudy(dir);
  for (const char* name : {"keys", "other"}) {
    Process make({app("demfem-dem"), "--make-curve-keys", (dir / name).string()}, dir / (std::string("make-") + name));
    REQUIRE(exitedOk(make.wait(10s)));
  }
  // The intruder knows the server's public key but has its own client key pair.
  fs::copy_file(dir / "keys" / "server.pub", dir / "other" / "server.pub", fs::copy_options::overwrite_existing);
  auto args = harmonicArgs(study_file);
  args.insert(args.end(), {"--curve-keys", (dir / "keys").string()});
  Server dem(dir, "dem", args);
  Process intruder(femArgs(study_file, dem.endpoint, dir / "out-bad", {"--curve-keys", (dir / "other").string(), "--timeout-s", "5"}),
                   dir / "intruder");
  CHECK_FALSE(exitedOk(intruder.wait(30s)));
  CHECK_THAT(intruder.err(), Catch::Contains("CurveZMQ"));
  // The rightful client is served by the same server afterwards.
  Process client(femArgs(study_file, dem.endpoint, dir / "out", {"--curve-keys", (dir / "keys").string(), "--steps", "5", "--quiet"}),
                 dir / "client");
  CHECK(exitedOk(client.wait(60s)));
  CHECK(exitedOk(dem.process.wait(20s)));
  fs::remove_all(dir);
}

TEST_CASE("a checkpointed coupled run resumed after a kill ends in the same state as an uninterrupted run", "[apps][physics]") {
  const fs::path dir = freshDir("resume");
  const fs::path study_file = fastQuickStudy(dir);
  const std::vector<std::string> run_args{"--steps", "200", "--checkpoint-every", "25", "--quiet"};
  {
    Server dem(dir, "dem-full", withCheckpoints(harmonicArgs(study_file), dir / "full"));
    Process fem(femArgs(study_file, dem.endpoint, dir / "full", run_args), dir / "fem-full");
    REQUIRE(exitedOk(fem.wait(120s)));
  }
  {
    Server dem(dir, "dem-killed", withCheckpoints(harmonicArgs(study_file), dir / "resumed"));
    Process fem(femArgs(study_file, dem.endpoint, dir / "resumed", run_args), dir / "fem-killed");
    // Kill both once the checkpoint after step 125 has been committed, mid-run.
    const fs::path committed = dir / "resumed" / "checkpoint" / "dem_125.ckpt";
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    while (!fs::exists(committed) && !fem.exited() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(2ms);
    REQUIRE_FALSE(fem.exited());
    fem.signal(SIGKILL);
    dem.process.signal(SIGKILL);
    fem.wait(10s);
  }
  REQUIRE(fs::exists(dir / "resumed" / "sensors.csv.partial"));
  {
    Server dem(dir, "dem-resumed", withCheckpoints(harmonicArgs(study_file), dir / "resumed"));
    auto args = run_args;
    args.push_back("--resume");
    Process fem(femArgs(study_file, dem.endpoint, dir / "resumed", args), dir / "fem-resumed");
    REQUIRE(exitedOk(fem.wait(120s)));
  }
  // Bit-identical: the whole sensor history and every keypoint displacement.
  CHECK(readText(dir / "resumed" / "sensors.csv") == readText(dir / "full" / "sensors.csv"));
  CHECK(readText(dir / "resumed" / "keypoint_displacements.f64") == readText(dir / "full" / "keypoint_displacements.f64"));
  fs::remove_all(dir);
}

namespace {

// studies/quick.json on a 140 x 80 mm bin filled 40 mm deep (about 500 particles) with the 120 x
// 20 mm tool inserted at 300 mm/s and dragged 20 mm at 100 mm/s: 95 + 200 FEM steps on the builtin
// DEM. The settled soil is deposited once into a directory shared by the runs of the test.
fs::path smallBuiltinStudy(const fs::path& dir) {
  nlohmann::json study = nlohmann::json::parse(readText(fastQuickStudy(dir)));
  useSmallBin(study);
  useShortStroke(study, 20);
  ::setenv("DEMFEM_SOIL_DIR", (dir / "soil").c_str(), 1);
  return writeStudy(study, dir / "small_builtin.json");
}

}  // namespace

TEST_CASE("a coupled run on the builtin DEM killed mid-run and resumed writes the same bytes as an uninterrupted run",
          "[apps][builtin][physics]") {
  const fs::path dir = freshDir("resume-builtin");
  const fs::path study_file = smallBuiltinStudy(dir);
  const std::vector<std::string> run_args{"--checkpoint-every", "50", "--quiet"};
  // This small bin's deposition may leave one stage at its time cap; the test is about resuming, not
  // about the soil, so the servers accept it.
  const std::vector<std::string> dem_args{"--backend", "builtin", "--study", study_file.string(), "--allow-unsettled-soil"};
  {
    // The first server deposits the soil before it binds.
    Process deposit({app("demfem-dem"), "--insecure", "--bind", "tcp://127.0.0.1:*", "--endpoint-file", (dir / "deposit.endpoint").string(),
                     "--backend", "builtin", "--study", study_file.string(), "--connect-timeout-s", "1",
                     "--allow-unsettled-soil"},
                    dir / "deposit");
    REQUIRE(waitForFile(dir / "deposit.endpoint", deposit, 240s));
    deposit.wait(20s);
  }
  {
    Server dem(dir, "dem-full", withCheckpoints(dem_args, dir / "full"));
    Process fem(femArgs(study_file, dem.endpoint, dir / "full", run_args), dir / "fem-full");
    REQUIRE(exitedOk(fem.wait(240s)));
  }
  {
    Server dem(dir, "dem-killed", withCheckpoints(dem_args, dir / "resumed"));
    Process fem(femArgs(study_file, dem.endpoint, dir / "resumed", run_args), dir / "fem-killed");
    // Kill both once the checkpoint after step 150 (in the drag) is committed; the run goes on to 295.
    const fs::path committed = dir / "resumed" / "checkpoint" / "dem_150.ckpt";
    const auto deadline = std::chrono::steady_clock::now() + 240s;
    while (!fs::exists(committed) && !fem.exited() && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(2ms);
    std::this_thread::sleep_for(100ms);  // into the steps after the checkpoint
    REQUIRE_FALSE(fem.exited());
    fem.signal(SIGKILL);
    dem.process.signal(SIGKILL);
    fem.wait(10s);
  }
  REQUIRE(fs::exists(dir / "resumed" / "sensors.csv.partial"));
  {
    Server dem(dir, "dem-resumed", withCheckpoints(dem_args, dir / "resumed"));
    auto args = run_args;
    args.push_back("--resume");
    Process fem(femArgs(study_file, dem.endpoint, dir / "resumed", args), dir / "fem-resumed");
    REQUIRE(exitedOk(fem.wait(240s)));
  }
  const auto rows = csvRows(dir / "full" / "sensors.csv");
  REQUIRE(rows.size() == 200);
  double largest_force = 0;
  for (const auto& row : rows) largest_force = std::max(largest_force, std::abs(row[2]));
  CHECK(largest_force > 0.1);  // the soil loaded the tool: the comparison is not vacuous
  // Bit-identical: the whole sensor history and every keypoint displacement.
  CHECK(readText(dir / "resumed" / "sensors.csv") == readText(dir / "full" / "sensors.csv"));
  CHECK(readText(dir / "resumed" / "keypoint_displacements.f64") == readText(dir / "full" / "keypoint_displacements.f64"));
  CHECK(nlohmann::json::parse(readText(dir / "resumed" / "sensors.json"))["complete"] == true);
  fs::remove_all(dir);
}
