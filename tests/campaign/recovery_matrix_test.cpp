// The recovery matrix's own machinery (docs/diagnosis.md, "Recovery matrix"): the Clopper-Pearson
// bounds its targets are judged by, and the generator's draws and detectable sizes.
#include "recovery_matrix.hpp"

#include <catch2/catch.hpp>


using namespace demfem::campaign::test;

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
