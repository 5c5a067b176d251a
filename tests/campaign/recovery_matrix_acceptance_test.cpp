// The recovery matrix as an acceptance test of `demfem diagnose` (docs/diagnosis.md, "Recovery
// matrix"): the first 30 draws of master seed 1 (12 single catalogue effects, 6 pairs, 6 effects
// outside the catalogue, 6 null cases) from the independent CalculiX generator, each diagnosed by
// the executable as a child process (two at a time, one thread each, with the generator's measured
// model-form tolerance). The matrix is written to
// recovery_matrix/ in the build directory (matrix.csv, matrix.md, draws.json) and printed. Each
// target (power >= 95 % at twice the detectable size, false discoveries <= 5 %, null false alarms
// <= 5 %, effects outside the catalogue answered "unexplained" >= 90 %, both members of a pair
// named >= 80 %) is asserted as not rejected by the draws at 95 % confidence (one-sided
// Clopper-Pearson bound on the wrong side of the target): with 30 draws the test fails only on a
// gross miss (8 single effects at >= 2x: 6 named pass the 95 % power target, 5 do not; 6 null
// draws: 1 false alarm passes the 5 % target, 2 do not). The 200-draw benchmark
// (demfem-bench-recovery-matrix) measures the rates.
#include "recovery_matrix.hpp"

#include <catch2/catch.hpp>

#include <fstream>
#include <iostream>

using namespace demfem::campaign::test;

TEST_CASE("the diagnosis recovers hidden weight-drop effects at the targets of the recovery matrix", "[campaign][recovery]") {
  const fs::path out = fs::path(DEMFEM_BINARY_DIR) / "recovery_matrix";
  fs::create_directories(out);
  RunSettings settings;
  settings.demfem = (fs::path(DEMFEM_BINARY_DIR) / "apps" / "demfem").string();
  settings.study = fs::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/narrow_weight_drop.json";
  nlohmann::json draws = nlohmann::json::array();
  const auto scored = runDraws(1, 0, 30, 2, out / "work", settings, [](int) { return false; }, [&](const Scored& s) {
    std::cout << s.draw.index << " " << s.draw.describe() << ": " << s.answer.verdict << " (" << s.answer.wall_s << " s)" << std::endl;
  });
  for (const Scored& s : scored) draws.push_back(drawJson(s));
  std::ofstream(out / "matrix.csv") << matrixCsv(scored);
  std::ofstream(out / "matrix.md") << matrixMarkdown(scored);
  std::ofstream(out / "draws.json") << draws.dump(1) << '\n';
  std::cout << matrixMarkdown(scored);
  fs::remove_all(out / "work");

  REQUIRE(scored.size() == 30);
  for (const Target& t : targets(scored)) {
    INFO(t.name << ": " << t.k << " of " << t.n << ", one-sided 95 % bound " << t.bound() << " against the target " << t.target);
    CHECK(t.n > 0);
    CHECK_FALSE(t.rejected());
  }
}
