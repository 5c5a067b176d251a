// The recovery matrix as an acceptance test of `demfem diagnose` (docs/diagnosis.md, "Recovery
// matrix"): the first 30 draws of master seed 1 (12 single catalogue effects, 6 pairs, 6 effects
// outside the catalogue, 6 null cases) from the independent beam generator, each diagnosed by the
// executable as a child process (two at a time, one thread each). The matrix is written to
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

TEST_CASE("the one-sided Clopper-Pearson bounds of the recovery matrix match the closed forms at 0 and n successes", "[campaign][recovery]") {
  // k = 0: upper bound 1 - alpha^(1/n); k = n: lower bound alpha^(1/n) (to 1e-9).
  CHECK(clopperPearsonUpper(0, 30, 0.05) == Approx(1 - std::pow(0.05, 1.0 / 30)).margin(1e-9));
  CHECK(clopperPearsonLower(30, 30, 0.05) == Approx(std::pow(0.05, 1.0 / 30)).margin(1e-9));
  // 6 of 8 at the 95 % target: P(X <= 6 | 0.95) = 0.057 > 0.05, not rejected; 5 of 8: 0.0058, rejected.
  CHECK_FALSE(Target{"", 6, 8, 0.95, true}.rejected());
  CHECK(Target{"", 5, 8, 0.95, true}.rejected());
  CHECK_FALSE(Target{"", 1, 6, 0.05, false}.rejected());
  CHECK(Target{"", 2, 6, 0.05, false}.rejected());
}

TEST_CASE("the draws of one master seed are the same every time and sized from 1x to 10x their detectable amount", "[campaign][recovery]") {
  for (int i = 0; i < 10; ++i) {
    const Draw a = drawCase(1, i), b = drawCase(1, i);
    CHECK(a.describe() == b.describe());
    CHECK(a.noise_seed == b.noise_seed);
    for (const Effect& e : a.effects) {
      CHECK(e.multiple() >= 1.0);
      CHECK(e.multiple() <= 10.0 + 1e-9);
    }
  }
  // A just-detectable effect moves the largest one-mode quantity by 3 standard errors (bisection to 0.1 %).
  const Detectability detectability(recoveryDaq(1));
  const int kind = kindIndex("added_mass");
  CHECK(detectability.largestZ(std::vector<Effect>{Effect{kind, 0, detectableAmount(kind, 0), 1}}) == Approx(3).epsilon(0.01));
}
