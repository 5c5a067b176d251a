// `demfem calibrate` as a process: the weight-drop preset end to end (stdout only the JSON with
// --json -, a valid calibrated study, a report) and bad --fit arguments (exit code 2, message naming
// the argument).
#include "process.hpp"

#include "../campaign/weight_drop_fixture.hpp"

#include <catch2/catch.hpp>

using namespace demfem::testing;

TEST_CASE("demfem calibrate --preset weight-drop writes the calibrated study and the JSON only on stdout", "[apps]") {
  const fs::path dir = freshDir("calibrate-cli");
  fs::create_directories(dir / "recs");
  const demfem::campaign::test::TruthSettings truth;
  demfem::campaign::test::writeRecordings(dir / "recs", {0.05, 0.1}, 2, truth);
  const std::string study = demfem::campaign::test::fixtureStudyPath().string();
  Process run({app("demfem"), "calibrate", study, (dir / "recs").string(), "--preset", "weight-drop", "--out", (dir / "out").string(),
               "--json", "-", "--no-plots", "--starts", "2"},
              dir / "calibrate");
  const int status = run.wait(240s);
  INFO(run.err());
  REQUIRE(exitedOk(status));
  const auto doc = nlohmann::json::parse(run.out());  // nothing else on stdout
  CHECK(doc["fitted"]["/tools/0/fem/E_Pa"]["value"].get<double>() == Approx(truth.E_Pa).epsilon(0.01));
  CHECK(doc["fitted"]["/tools/0/fem/alpha_s"]["value"].get<double>() == Approx(truth.alpha_s).epsilon(0.05));
  CHECK(doc["model_runs"].get<int>() > 0);
  const demfem::study::Study calibrated = demfem::study::loadStudy(dir / "out" / "calibrated_study.json");
  CHECK(calibrated.tools[0].fem.youngs_Pa == Approx(truth.E_Pa).epsilon(0.01));
  CHECK(readText(dir / "out" / "report.md").find("Plots were not drawn") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("demfem calibrate rejects a --fit path that is not in the study, naming the argument", "[apps]") {
  const fs::path dir = freshDir("calibrate-cli-bad");
  fs::create_directories(dir / "recs");
  demfem::campaign::test::writeRecordings(dir / "recs", {0.05}, 1, {});
  Process run({app("demfem"), "calibrate", demfem::campaign::test::fixtureStudyPath().string(), (dir / "recs").string(), "--fit",
               "/tools/0/fem/Young=1:2", "--out", (dir / "out").string(), "--quiet"},
              dir / "calibrate");
  const int status = run.wait(60s);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 2);
  CHECK_THAT(run.err(), Catch::Matchers::Contains("--fit '/tools/0/fem/Young=1:2'") && Catch::Matchers::Contains("no value at"));
  CHECK_FALSE(fs::exists(dir / "out" / "report.md"));
  fs::remove_all(dir);
}
