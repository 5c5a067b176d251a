// `demfem run`: the two-process local run over ipc://, with the harmonic test backend.
#include "process.hpp"

#include <catch2/catch.hpp>

using namespace demfem::testing;

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

TEST_CASE("Ctrl-C on demfem run stops both processes and marks the outputs incomplete", "[apps]") {
  const fs::path dir = freshDir("local-run-int");
  const fs::path study = fastQuickStudy(dir);
  Process run({app("demfem"), "run", study.string(), "--backend", "harmonic", "--output", (dir / "out").string(), "--quiet"},
              dir / "demfem");
  const fs::path partial = dir / "out" / "sensors.csv.partial";
  const auto deadline = std::chrono::steady_clock::now() + 120s;
  while (!(fs::exists(partial) && fs::file_size(partial) > 1000) && !run.exited() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  REQUIRE_FALSE(run.exited());
  run.signal(SIGINT);
  const int status = run.wait(30s);
  CHECK(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGINT);
  CHECK(readText(dir / "out" / "sensors.csv").find("\n# incomplete: ") != std::string::npos);
  CHECK(nlohmann::json::parse(readText(dir / "out" / "sensors.json"))["complete"] == false);
  // Its temporary directory (the ipc socket) is gone too, although the signal skipped destructors.
  CHECK_FALSE(fs::exists(fs::temp_directory_path() / ("demfem-run-" + std::to_string(run.pid()))));
  fs::remove_all(dir);
}
