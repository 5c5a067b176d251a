// `demfem run`: the two-process local run over ipc://, with the harmonic test backend.
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/study/study.hpp"
#include "process.hpp"

#include <catch2/catch.hpp>

#include <cstdlib>
#include <algorithm>

using namespace demfem::testing;

namespace {

// The run directory (under the temp directory) whose owner file names `pid`; empty if none.
fs::path runDirectoryOf(pid_t pid) {
  for (const auto& entry : fs::directory_iterator(fs::temp_directory_path())) {
    if (entry.path().filename().string().rfind("demfem-run-", 0) != 0) continue;
    long owner = 0;
    std::ifstream(entry.path() / "demfem.pid") >> owner;
    if (owner == pid) return entry.path();
  }
  return {};
}

// Children of `pid` (from /proc).
std::vector<pid_t> childrenOf(pid_t pid) {
  std::vector<pid_t> children;
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string line;
    std::getline(stat, line);
    const auto close = line.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(line.substr(close + 2));
    char state = 0;
    long ppid = 0;
    rest >> state >> ppid;
    if (ppid == pid) children.push_back(static_cast<pid_t>(std::stol(name)));
  }
  return children;
}

// Gone or a zombie (a container's init may not reap orphans).
bool dead(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return true;
  const auto close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() && line[close + 2] == 'Z';
}

}  // namespace

TEST_CASE("demfem run starts both processes over ipc and marks a run cut by --steps incomplete", "[apps]") {
  const fs::path dir = freshDir("local-run");
  const fs::path study = fastQuickStudy(dir);
  Process run({app("demfem"), "run", study.string(), "--backend", "harmonic", "--steps", "120", "--output",
               (dir / "out").string(), "--json", (dir / "summary.json").string()},
              dir / "demfem");
  const int status = run.wait(180s);
  INFO(run.err());
  REQUIRE(exitedOk(status));  // the user asked for 120 steps and got them
  const auto sidecar = nlohmann::json::parse(readText(dir / "out" / "sensors.json"));
  CHECK(sidecar["complete"] == false);
  CHECK_THAT(sidecar["incomplete_reason"].get<std::string>(), Catch::StartsWith("stopped after 120 of "));
  CHECK(readText(dir / "out" / "sensors.csv").find("\n# incomplete: stopped after 120 of ") != std::string::npos);
  const auto summary = nlohmann::json::parse(readText(dir / "summary.json"));
  CHECK(summary["complete"] == false);
  CHECK(summary["steps"] == 120);
  CHECK(summary["planned_steps"] == sidecar["planned_steps"]);
  CHECK(summary["backend"] == "harmonic");
  CHECK(csvRows(dir / "out" / "sensors.csv").size() == summary["drag_steps"].get<std::size_t>());
  CHECK_FALSE(fs::exists(dir / "out" / "sensors.csv.partial"));
  fs::remove_all(dir);
}

namespace {

// Returns once the run's dir/out/sensors.csv.partial holds more than 1000 bytes (within 120 s);
// the run must still be running then.
void waitForSensors(Process& run, const fs::path& dir) {
  const fs::path partial = dir / "out" / "sensors.csv.partial";
  const auto deadline = std::chrono::steady_clock::now() + 120s;
  while (!(fs::exists(partial) && fs::file_size(partial) > 1000) && !run.exited() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  REQUIRE_FALSE(run.exited());
}

}  // namespace

TEST_CASE("Ctrl-C on demfem run stops both processes and marks the outputs incomplete", "[apps]") {
  const fs::path dir = freshDir("local-run-int");
  const fs::path study = fastQuickStudy(dir);
  Process run({app("demfem"), "run", study.string(), "--backend", "harmonic", "--output", (dir / "out").string(), "--quiet"},
              dir / "demfem");
  waitForSensors(run, dir);
  run.signal(SIGINT);
  const int status = run.wait(30s);
  CHECK(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGINT);
  CHECK(readText(dir / "out" / "sensors.csv").find("\n# incomplete: ") != std::string::npos);
  CHECK(nlohmann::json::parse(readText(dir / "out" / "sensors.json"))["complete"] == false);
  // Its temporary directory (the ipc socket) is gone too, although the signal skipped destructors.
  CHECK(runDirectoryOf(run.pid()).empty());
  fs::remove_all(dir);
}

TEST_CASE("SIGKILL on demfem run takes both children down, and the next run removes its directory", "[apps]") {
  const fs::path dir = freshDir("local-run-kill");
  const fs::path study = fastQuickStudy(dir);
  Process run({app("demfem"), "run", study.string(), "--backend", "harmonic", "--output", (dir / "out").string(), "--quiet"},
              dir / "demfem");
  waitForSensors(run, dir);
  const fs::path work = runDirectoryOf(run.pid());
  REQUIRE_FALSE(work.empty());
  CHECK((fs::status(work).permissions() & (fs::perms::group_all | fs::perms::others_all)) == fs::perms::none);
  const std::vector<pid_t> children = childrenOf(run.pid());
  REQUIRE(children.size() == 2);
  run.signal(SIGKILL);
  run.wait(10s);
  const auto gone_by = std::chrono::steady_clock::now() + 20s;
  const auto allDead = [&] { return std::all_of(children.begin(), children.end(), dead); };
  while (!allDead() && std::chrono::steady_clock::now() < gone_by) std::this_thread::sleep_for(20ms);
  CHECK(allDead());
  // The FEM client was told (SIGTERM) and marked its outputs incomplete.
  CHECK(nlohmann::json::parse(readText(dir / "out" / "sensors.json"))["complete"] == false);
  // Nobody could remove the directory of a SIGKILLed front end; the next run does.
  CHECK(fs::exists(work));
  Process next({app("demfem"), "run", study.string(), "--backend", "harmonic", "--steps", "5", "--output",
                (dir / "next").string(), "--quiet"},
               dir / "next");
  CHECK(exitedOk(next.wait(120s)));
  CHECK_FALSE(fs::exists(work));
  fs::remove_all(dir);
}

TEST_CASE("an unsettled soil stops demfem run, demfem-dem and demfem campaign unless allowed, and its figures go into sensors.json",
          "[apps][soil]") {
  const fs::path dir = freshDir("unsettled-soil");
  const fs::path study_file = fastQuickStudy(dir);
  const fs::path soil_dir = dir / "soil";
  ::setenv("DEMFEM_SOIL_DIR", soil_dir.c_str(), 1);  // inherited by the processes below
  const auto study = demfem::study::loadStudy(study_file);
  // A soil whose deposition hit its time cap in 3 of 5 stages, the final one among them: a few
  // grains resting on the floor, away from the tool's path.
  demfem::adapter::SettledSoil soil;
  soil.soil_hash = demfem::study::soilHash(study);
  soil.seed = study.soil.deposition_seed;
  soil.settling = {2.5e-6, study.soil.settle_kinetic_energy_J, 5, 3, true, 7.5, 0.0, 0.0};
  const auto deepest = static_cast<std::int32_t>(study.soil.layers.size()) - 1;
  for (int i = 0; i < 6; ++i)
    soil.particles.push_back({{0.02 + 0.012 * i, study.soil.diameter_max_m / 2, 0.02}, study.soil.diameter_max_m / 2, deepest});
  const fs::path soil_file = demfem::adapter::settledSoilFile(study, soil_dir);
  demfem::adapter::writeSettledSoil(soil_file, soil);

  Process refused({app("demfem"), "run", study_file.string(), "--backend", "builtin", "--steps", "5", "--output",
                   (dir / "refused").string()},
                  dir / "refused-run");
  CHECK(WIFEXITED(refused.wait(120s)));
  CHECK_THAT(refused.err(), Catch::Contains(soil_file.string()) && Catch::Contains("is not settled") &&
                                Catch::Contains("final settling phase hit its time cap") && Catch::Contains("--allow-unsettled-soil"));
  CHECK_FALSE(fs::exists(dir / "refused" / "sensors.json"));

  Process server({app("demfem-dem"), "--study", study_file.string(), "--backend", "builtin", "--bind",
                  "ipc://" + (dir / "dem.ipc").string()},
                 dir / "refused-dem");
  const int server_status = server.wait(120s);
  CHECK((WIFEXITED(server_status) && WEXITSTATUS(server_status) != 0));
  CHECK_THAT(server.err(), Catch::Contains("is not settled"));

  Process allowed({app("demfem"), "run", study_file.string(), "--backend", "builtin", "--steps", "5", "--output",
                   (dir / "out").string(), "--allow-unsettled-soil", "--quiet"},
                  dir / "allowed-run");
  const int status = allowed.wait(240s);
  INFO(allowed.err());
  REQUIRE(exitedOk(status));
  const auto record = nlohmann::json::parse(readText(dir / "out" / "sensors.json")).at("soil");
  CHECK(record.at("settled") == false);
  CHECK(record.at("stages_capped") == 3);
  CHECK(record.at("final_phase_capped") == true);
  CHECK(record.at("stages") == 5);
  CHECK(record.at("kinetic_energy_J") == 2.5e-6);
  CHECK(record.at("particles") == soil.particles.size());
  CHECK(record.at("file") == soil_file.string());
  CHECK(record.at("file_checksum") == demfem::adapter::settledSoilChecksum(soil_file));
  CHECK(record.at("deposition_backend") == "builtin");

  // The campaign checks every case's soil before it runs any; allowed, it records the soil the same way.
  const auto campaign = [&](const std::string& tag, bool allow) {
    std::vector<std::string> args{app("demfem"), "campaign", study_file.string(), "--dir", (dir / tag).string(), "--steps", "5", "--quiet"};
    if (allow) args.push_back("--allow-unsettled-soil");
    return Process(args, dir / (tag + "-campaign"));
  };
  Process campaign_refused = campaign("campaign-refused", false);
  const int refused_status = campaign_refused.wait(120s);
  CHECK((WIFEXITED(refused_status) && WEXITSTATUS(refused_status) != 0));
  CHECK_THAT(campaign_refused.err(), Catch::Contains("case quick_fast") && Catch::Contains(soil_file.string()) &&
                                         Catch::Contains("final settling phase hit its time cap") &&
                                         Catch::Contains("--allow-unsettled-soil"));
  CHECK_FALSE(fs::exists(dir / "campaign-refused" / "quick_fast" / "sensors.json"));
  Process campaign_allowed = campaign("campaign-allowed", true);
  const int allowed_status = campaign_allowed.wait(240s);
  INFO(campaign_allowed.err());
  REQUIRE(exitedOk(allowed_status));
  CHECK(nlohmann::json::parse(readText(dir / "campaign-allowed" / "quick_fast" / "sensors.json")).at("soil").at("settled") == false);
  fs::remove_all(dir);
}
