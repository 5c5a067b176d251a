// With `--json -` every command's standard output is exactly one JSON document (progress and
// messages go to standard error), checked by parsing the whole of standard output.
#include "process.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <thread>

using namespace demfem::testing;

namespace {

// A copy of studies/quick.json on a 80 x 50 mm bin (about 170 particles, a few seconds to deposit)
// with the 120 x 20 mm tool of fastQuickStudy and a 10 mm stroke.
fs::path tinyStudy(const fs::path& dir) {
  nlohmann::json study = nlohmann::json::parse(readText(fastQuickStudy(dir)));
  study["soil"]["bin"]["length_mm"] = 80;
  study["soil"]["bin"]["width_mm"] = 50;
  study["tools"][0]["motion"]["stroke_mm"] = 10;
  study["tools"][0]["motion"]["start_z_mm"] = 40;
  return writeStudy(study, dir / "tiny.json");
}

// studies/weight_drop_1kg.json with the 120 x 20 mm tool for 0.5 s.
fs::path shortWeightDrop(const fs::path& dir) {
  nlohmann::json study = shippedStudyJson("weight_drop_1kg.json");
  useSmallTool(study);
  study["weight_drop"]["duration_s"] = 0.5;
  return writeStudy(study, dir / "weight_drop_short.json");
}

}  // namespace

TEST_CASE("demfem validate, deposit and run print one JSON document with --json -", "[apps]") {
  const fs::path dir = freshDir("json-demfem");
  const fs::path study = tinyStudy(dir);
  const auto validate = jsonStdout({app("demfem"), "validate", study.string(), "--json", "-"}, dir / "validate");
  CHECK(validate["studies"][0]["valid"] == true);

  const auto deposit =
      jsonStdout({app("demfem"), "deposit", study.string(), "--soil-dir", (dir / "soil").string(), "--json", "-"}, dir / "deposit");
  CHECK(deposit["reused"] == false);
  CHECK(deposit["particles"].get<int>() > 100);

  // validate's cost: insertion (18 mm depth + 10.5 mm clearance) / 300 mm/s = 95 FEM steps of 1 ms
  // and a 10 mm drag at 36.14 mm/s = 277 steps; DEM steps over the same 0.372 s; the particle count
  // bounds the deposited one from above (settled soils hold 0.66-0.89 of it: the full paper bin with
  // the EDEM and the hooke laws, this bin); the machine's cores by default.
  const auto& cost = validate["studies"][0]["cost"];
  CHECK(cost["fem_steps"] == 95 + 277);
  CHECK(cost["dem_steps"].get<double>() == Approx(0.372 / cost["dem_step_s"].get<double>()).margin(1.0));
  // quick.json's rolling law, epsd, has no spin scale, so no regularisation step (only edem-standard
  // has one: soil.contact.rolling_regularisation_fraction).
  CHECK(cost["rolling_regularisation_step_s"].is_null());
  const double deposited = deposit["particles"].get<double>();
  CHECK(cost["particles_at_most"].get<double>() >= deposited);
  CHECK(cost["particles_at_most"].get<double>() < deposited / 0.6);
  CHECK(cost["threads"].get<unsigned>() == std::max(1u, std::thread::hardware_concurrency()));
  CHECK(cost["wall_time_s"].get<double>() > 0.0);

  const auto run = jsonStdout({app("demfem"), "run", study.string(), "--backend", "harmonic", "--steps", "20", "--output",
                               (dir / "out").string(), "--json", "-"},
                              dir / "run");
  CHECK(run["steps"] == 20);
  CHECK(run["backend"] == "harmonic");
  fs::remove_all(dir);
}

TEST_CASE("demfem-fem run against a demfem-dem server prints one JSON document with --json -", "[apps]") {
  const fs::path dir = freshDir("json-fem-run");
  const fs::path study = tinyStudy(dir);
  const fs::path endpoint_file = dir / "endpoint";
  Process dem({app("demfem-dem"), "--study", study.string(), "--backend", "harmonic", "--bind", "ipc://" + (dir / "dem.ipc").string(),
               "--endpoint-file", endpoint_file.string()},
              dir / "dem");
  REQUIRE(waitForFile(endpoint_file, dem, 60s));
  const auto run = jsonStdout({app("demfem-fem"), "run", study.string(), "--connect", endpointFrom(endpoint_file), "--steps", "20",
                               "--output", (dir / "out").string(), "--json", "-"},
                              dir / "fem");
  CHECK(run["steps"] == 20);
  CHECK(exitedOk(dem.wait(30s)));
  // The server's status lines are not on its standard output either.
  CHECK(dem.out().empty());
  fs::remove_all(dir);
}

TEST_CASE("demfem-fem modal, static and weight-drop print one JSON document with --json -", "[apps]") {
  const fs::path dir = freshDir("json-fem");
  const fs::path study = tinyStudy(dir);
  const auto modal = jsonStdout({app("demfem-fem"), "modal", study.string(), "-n", "2", "--json", "-"}, dir / "modal");
  CHECK(modal["modes"].size() == 2);
  const auto loaded = jsonStdout({app("demfem-fem"), "static", study.string(), "--tip-load-N", "10", "--json", "-"}, dir / "static");
  CHECK(loaded["load_N"] == 10.0);
  const fs::path csv = dir / "drop" / "pmma_1kg.csv";
  const auto drop = jsonStdout({app("demfem-fem"), "weight-drop", shortWeightDrop(dir).string(), "--csv", csv.string(), "--json", "-"},
                               dir / "weight-drop");
  // The fitted steady value (the asymptote, not the still ringing tail's mean) is the static
  // solution within 1 %.
  CHECK(drop["force"]["steady_N"].get<double>() == Approx(drop["static_force_N"].get<double>()).epsilon(0.01));
  CHECK(fs::exists(fs::path(csv).replace_extension(".json")));
  fs::remove_all(dir);
}

TEST_CASE("demfem evaluate and compare print one JSON document with --json -, the weight-drop recording taken as it is",
          "[apps]") {
  const fs::path dir = freshDir("json-analysis");
  const fs::path measured = sourceDir() / "examples" / "data" / "measured";
  const auto evaluation =
      jsonStdout({app("demfem"), "evaluate", measured.string(), "--out", (dir / "eval").string(), "--no-plots", "--json", "-"},
                 dir / "evaluate");
  CHECK(evaluation["soil_bin_cases"].size() == 2);

  // demfem-fem weight-drop's CSV + sidecar (tool PMMA, 1 kg) is a simulated recording of the
  // measured PMMA 1 kg case: compare needs no sidecar written by hand and no --simulated-tool.
  const fs::path simulated = dir / "simulated";
  Process drop({app("demfem-fem"), "weight-drop", shortWeightDrop(dir).string(), "--csv", (simulated / "pmma_1kg.csv").string(), "--quiet"},
               dir / "weight-drop");
  REQUIRE(exitedOk(drop.wait(240s)));
  const auto comparison = jsonStdout({app("demfem"), "compare", measured.string(), simulated.string(), "--out", (dir / "cmp").string(),
                                      "--no-plots", "--json", "-"},
                                     dir / "compare");
  REQUIRE(comparison["calibration"].size() == 2);  // one row per signal of the one case
  CHECK(comparison["calibration"][0]["mass_kg"] == 1.0);
  CHECK(comparison["calibration"][0]["tool"] == "PMMA");
  fs::remove_all(dir);
}

TEST_CASE("demfem run on a weight-drop study points to demfem-fem weight-drop", "[apps]") {
  const fs::path dir = freshDir("run-weight-drop");
  const std::string study = (sourceDir() / "studies" / "weight_drop_1kg.json").string();
  Process run({app("demfem"), "run", study}, dir / "run");
  const int status = run.wait(30s);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 2);
  CHECK_THAT(run.err(), Catch::Contains("demfem-fem weight-drop " + study));
  fs::remove_all(dir);
}
