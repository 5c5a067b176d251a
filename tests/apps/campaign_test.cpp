// `demfem campaign`: a shortened paper-style case (a few hundred FEM steps on the built-in DEM) run,
// refused to a second campaign on its directory while it runs, interrupted by Ctrl-C after its first
// checkpoint, resumed, not rerun once finished (nor after an edited note; refused after an edited
// value), equal to an uninterrupted run, and reported beside the paper's numbers.
#include "process.hpp"

#include <catch2/catch.hpp>

#include <cstdlib>

using namespace demfem::testing;

namespace {

// studies/quick.json made cheap (fastQuickStudy) with a 15 mm stroke: about 450 FEM steps, ParaView
// files every 50 steps, the study's own output directory dir/elsewhere (a campaign does not use it).
fs::path shortCase(const fs::path& dir) {
  nlohmann::json study = nlohmann::json::parse(readText(fastQuickStudy(dir)));
  study["tools"][0]["motion"]["stroke_mm"] = 15;
  study["dem"]["threads"] = 1;
  study["output"]["vtk_every"] = 50;
  study["output"]["directory"] = (dir / "elsewhere").string();
  const fs::path file = dir / "pmma_short.json";
  std::ofstream(file) << study.dump(2);
  return file;
}

nlohmann::json caseOf(const fs::path& summary) { return nlohmann::json::parse(readText(summary))["cases"].at(0); }

}  // namespace

TEST_CASE("demfem campaign resumes an interrupted case from its checkpoint, skips a finished one and reports it", "[apps]") {
  const fs::path dir = freshDir("campaign");
  ::setenv("DEMFEM_SOIL_DIR", (dir / "soil").c_str(), 1);  // inherited by the processes below
  const fs::path study = shortCase(dir);
  const fs::path runs = dir / "runs", run_dir = runs / "pmma_short";
  const auto campaign = [&](const fs::path& runs_dir, const std::string& tag) {
    return std::vector<std::string>{app("demfem"), "campaign", study.string(), "--dir", runs_dir.string(), "--checkpoint-every", "40",
                                    "--json", (dir / (tag + ".json")).string()};
  };

  Process first(campaign(runs, "first"), dir / "first");
  const fs::path checkpoint = run_dir / "checkpoint" / "fem_state.bin";
  REQUIRE(waitForFile(checkpoint, first, 300s));
  // The run record holds the call's time from its first checkpoint on: a call killed now (a session's
  // end) still counts what it kept.
  REQUIRE(waitForFile(run_dir / "campaign_case.json", first, 60s));
  const nlohmann::json running_record = nlohmann::json::parse(readText(run_dir / "campaign_case.json"));
  CHECK(running_record["calls"] == 1);
  CHECK(running_record["wall_time_s"].get<double>() > 0);
  // A second campaign on the same directory while the first runs: refused at once, naming the
  // holder (the resumed run below equalling the uninterrupted one shows it wrote nothing there).
  Process intruder(campaign(runs, "intruder"), dir / "intruder");
  const int intruder_status = intruder.wait(60s);
  REQUIRE(WIFEXITED(intruder_status));
  CHECK(WEXITSTATUS(intruder_status) != 0);
  CHECK_THAT(intruder.err(), Catch::Contains(runs.string() + " is in use by another run (process " + std::to_string(first.pid()) + ")"));
  first.signal(SIGINT);
  const int status = first.wait(60s);
  INFO(first.err());
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 130);
  CHECK(nlohmann::json::parse(readText(run_dir / "sensors.json"))["complete"] == false);

  Process second(campaign(runs, "second"), dir / "second");
  REQUIRE(exitedOk(second.wait(300s)));
  const nlohmann::json resumed = caseOf(dir / "second.json");
  CHECK(resumed["state"] == "done");
  CHECK(resumed["resumed"] == true);
  const nlohmann::json record = nlohmann::json::parse(readText(run_dir / "campaign_case.json"));
  CHECK(record["calls"] == 2);
  CHECK(record["wall_time_s"].get<double>() > running_record["wall_time_s"].get<double>());
  CHECK(nlohmann::json::parse(readText(run_dir / "sensors.json"))["complete"] == true);

  Process third(campaign(runs, "third"), dir / "third");
  REQUIRE(exitedOk(third.wait(120s)));
  CHECK(caseOf(dir / "third.json")["done_before"] == true);
  // The notes are free text: a note edited after the run leaves it the same case. A value is not.
  nlohmann::json edited = nlohmann::json::parse(readText(study));
  edited["notes"] = "a note written after the run";
  std::ofstream(study) << edited.dump(2);
  Process noted(campaign(runs, "noted"), dir / "noted");
  REQUIRE(exitedOk(noted.wait(120s)));
  CHECK(caseOf(dir / "noted.json")["done_before"] == true);
  edited["tools"][0]["motion"]["depth_mm"] = edited["tools"][0]["motion"]["depth_mm"].get<double>() + 1;
  std::ofstream(study) << edited.dump(2);
  Process changed(campaign(runs, "changed"), dir / "changed");
  const int changed_status = changed.wait(120s);
  REQUIRE(WIFEXITED(changed_status));
  CHECK(WEXITSTATUS(changed_status) != 0);
  CHECK_THAT(changed.err(), Catch::Contains(run_dir.string() + " holds a finished run of another study"));
  edited["tools"][0]["motion"]["depth_mm"] = edited["tools"][0]["motion"]["depth_mm"].get<double>() - 1;
  std::ofstream(study) << edited.dump(2);

  // The built-in DEM's checkpoint restores bit for bit: the resumed record is the uninterrupted one.
  Process straight(campaign(dir / "straight", "straight"), dir / "straight");
  REQUIRE(exitedOk(straight.wait(300s)));
  CHECK(readText(run_dir / "sensors.csv") == readText(dir / "straight" / "pmma_short" / "sensors.csv"));
  // Every file of the run in its run directory, the DEM's beside the FEM's, the resumed series the
  // uninterrupted one.
  for (const char* series : {"particles.pvd", "dem-PMMA.pvd", "fem-PMMA.pvd"})
    CHECK(readText(run_dir / "vtk" / series) == readText(dir / "straight" / "pmma_short" / "vtk" / series));
  CHECK_FALSE(fs::exists(dir / "elsewhere"));

  Process report({app("demfem"), "campaign", study.string(), "--dir", runs.string(), "--report", (dir / "report").string(), "--json",
                  (dir / "report.json").string()},
                 dir / "report");
  const int report_status = report.wait(120s);
  INFO(report.err());
  REQUIRE(exitedOk(report_status));
  const nlohmann::json reported = caseOf(dir / "report.json");
  CHECK(reported["finished"] == true);
  CHECK(reported["stroke_mm"] == 15.0);
  // The soil pushes against the travel: a positive load-cell force, and a spectrum that falls off.
  CHECK(reported["force_mean_N"].get<double>() > 0);
  CHECK(reported["fit_b"].get<double>() < 0);
  // Fig. 16's measures from the particle files, at 300 mm scaled by the stroke (15 / 600 mm): the
  // frame nearest 7.5 mm, soil in motion in front of the tool.
  CHECK(reported["soil_motion_at_mm"].get<double>() == Approx(7.5).margin(1.0));
  CHECK(reported["moving_depth_mm"].get<double>() > 0);
  CHECK(reported["front_particles"].get<int>() > 0);
  const std::string md = readText(dir / "report" / "paper-reproduction.md");
  CHECK(md.find("| pmma_short | PMMA | DEM-FEM | 18 |") != std::string::npos);
  CHECK(md.find("| 46 |") != std::string::npos);  // Table 1's hours of the PMMA 18 mm case beside ours
  CHECK(fs::exists(dir / "report" / "plots" / "paper_force_curves.svg"));
  fs::remove_all(dir);
}
