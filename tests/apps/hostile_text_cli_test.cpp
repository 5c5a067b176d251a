// Text from a recording reaches plot titles, legends and reports, never an interpreter: every
// command that plots (evaluate, compare, calibrate, diagnose) is run with plots on, on recordings
// whose sidecars name the tool with gnuplot's command substitutions, and must leave no trace of
// them on the machine (docs/reliability.md, "No code from data").
#include "process.hpp"

#include "../campaign/weight_drop_fixture.hpp"

#include <catch2/catch.hpp>

using namespace demfem::testing;

namespace {

// A tool name that runs `touch` under every quoting gnuplot knows: backquotes (substituted in
// double-quoted strings and on the command line), a closing double quote followed by system(), a
// single quote, a macro. Each would create a file in `dir` if the text reached gnuplot as script.
std::string hostileName(const fs::path& dir) {
  const std::string mark = (dir / "executed").string();
  return "PMMA `touch " + mark + "-backquote` \" . system(\"touch " + mark + "-system\") . \" ' . system('touch " + mark +
         "-single') . ' @mark $(touch " + mark + "-dollar)";
}

// Copies every recording of `from` into `to` with the sidecars' tool set to `tool`.
void copyWithTool(const fs::path& from, const fs::path& to, const std::string& tool) {
  fs::create_directories(to);
  for (const auto& entry : fs::directory_iterator(from)) {
    if (entry.path().extension() == ".json") {
      nlohmann::json sidecar = nlohmann::json::parse(readText(entry.path()));
      sidecar["tool"] = tool;
      std::ofstream(to / entry.path().filename()) << sidecar.dump(2) << "\n";
    } else {
      fs::copy_file(entry.path(), to / entry.path().filename());
    }
  }
}

// Nothing named executed* appears beside the recordings.
int tracesIn(const fs::path& dir) {
  int traces = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().filename().string().rfind("executed", 0) == 0) ++traces;
  return traces;
}

void runPlotting(const std::vector<std::string>& args, const fs::path& log_stem) {
  Process p(args, log_stem);
  const int status = p.wait(std::chrono::seconds(240));
  INFO(p.err());
  REQUIRE(exitedOk(status));
}

}  // namespace

TEST_CASE("evaluate and compare draw recordings whose tool names hold gnuplot commands as plain text", "[apps]") {
  const fs::path dir = freshDir("hostile-evaluate");
  const std::string tool = hostileName(dir);
  copyWithTool(sourceDir() / "examples" / "data" / "measured", dir / "measured", tool);
  copyWithTool(sourceDir() / "examples" / "data" / "simulated", dir / "simulated", tool);

  runPlotting({app("demfem"), "evaluate", (dir / "measured").string(), "--out", (dir / "evaluated").string()}, dir / "evaluate");
  runPlotting({app("demfem"), "compare", (dir / "measured").string(), (dir / "simulated").string(), "--out", (dir / "compared").string()},
              dir / "compare");
  CHECK(tracesIn(dir) == 0);
  // The plots were drawn, with the name as text (gnuplot writes a single quote as &apos; in SVG).
  int svgs = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    if (entry.path().extension() == ".svg") ++svgs;
  CHECK(svgs >= 2);
  CHECK(readText(dir / "compared" / "report.md").find("touch") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("a sidecar whose tool name holds a line break is refused, naming the file and the key", "[apps]") {
  const fs::path dir = freshDir("hostile-newline");
  copyWithTool(sourceDir() / "examples" / "data" / "measured", dir / "measured", "PMMA\nsystem('touch " + (dir / "executed").string() + "')");
  Process p({app("demfem"), "evaluate", (dir / "measured").string(), "--out", (dir / "evaluated").string()}, dir / "evaluate");
  const int status = p.wait(std::chrono::seconds(120));
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) != 0);
  CHECK(p.err().find(".json") != std::string::npos);
  CHECK(p.err().find("/tool") != std::string::npos);
  CHECK(p.err().find("control character") != std::string::npos);
  CHECK(tracesIn(dir) == 0);
  CHECK_FALSE(fs::exists(dir / "evaluated" / "report.md"));
  fs::remove_all(dir);
}

TEST_CASE("calibrate and diagnose draw weight recordings whose tool names hold gnuplot commands as plain text", "[apps]") {
  const fs::path dir = freshDir("hostile-calibrate");
  fs::create_directories(dir / "plain");
  demfem::campaign::test::writeRecordings(dir / "plain", {0.05, 0.1}, 1, {});
  copyWithTool(dir / "plain", dir / "recs", hostileName(dir));
  const std::string study = demfem::campaign::test::fixtureStudyPath().string();

  runPlotting({app("demfem"), "calibrate", study, (dir / "recs").string(), "--preset", "weight-drop", "--out", (dir / "calibrated").string(),
               "--starts", "1", "--max-evaluations", "6", "--quiet"},
              dir / "calibrate");
  runPlotting({app("demfem"), "diagnose", study, (dir / "recs").string(), "--cause", "young_modulus", "--out", (dir / "diagnosed").string(),
               "--max-evaluations", "6", "--quiet"},
              dir / "diagnose");
  CHECK(tracesIn(dir) == 0);
  CHECK(fs::exists(dir / "calibrated" / "report.md"));
  CHECK(fs::exists(dir / "diagnosed" / "report.md"));
  fs::remove_all(dir);
}
