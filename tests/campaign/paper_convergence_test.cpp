// The verdict of the time-step convergence study (campaign/paper_convergence.hpp) on hand-made
// points: the seed scatter is the pooled sample standard deviation between seeds, a fraction's
// change is its seed-by-seed difference to the finest step, a fraction is converged when it and
// every finer one change by at most one scatter, a failed run enters nothing, and the JSON round
// trip keeps the verdict.
#include "demfem/campaign/paper_convergence.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace demfem::campaign;
using Catch::Detail::Approx;

namespace {

ConvergencePoint point(double fraction, std::uint64_t seed, double force, double deformation, double b) {
  ConvergencePoint p;
  p.dt_fraction = fraction;
  p.seed = seed;
  p.force_mean_N = force;
  p.deformation_mean_mm = deformation;
  p.fit_b = b;
  return p;
}

}  // namespace

TEST_CASE("the converged fraction is the coarsest whose seed-paired change is within one seed scatter and two standard errors",
          "[campaign]") {
  // Seeds 1-3; seed s's packing gives +0.1 (s - 2) N at every step (the pairing removes it from the
  // changes), and `noise` x (1, -2, 1) more that differs between steps (it gives the changes a
  // standard error of exactly `noise`). Deformation is a hundredth of force.
  std::vector<ConvergencePoint> points;
  const auto add = [&](double fraction, double force, double deformation, double b, double noise) {
    constexpr double e[] = {1, -2, 1};
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      const double d = 0.1 * (static_cast<double>(seed) - 2.0) + noise * e[seed - 1];
      points.push_back(point(fraction, seed, force + d, deformation + 0.01 * d, b + d));
    }
  };
  add(0.05, 7.0, 0.060, -1.5, 0);
  add(0.1, 7.08, 0.0608, -1.45, 0.05);   // changes 0.08 N, 0.0008 mm, 0.05, each +- 0.05 (0.0005): within
  add(0.2, 7.15, 0.0598, -1.55, 0.05);   // 0.15 N: beyond one scatter
  ConvergencePoint failed = point(0.4, 1, 0, 0, 0);
  failed.failure = "builtin DEM blew up at step 10";
  points.push_back(failed);
  const ConvergenceSummary s = summarize(points, "test");
  CHECK(s.scatter_seeds == 3);
  // Pooled: variances 0.01 (0.05) and 0.0175 (0.1, 0.2), two degrees of freedom each.
  CHECK(s.force_scatter_N == Approx(std::sqrt(0.045 / 3)).epsilon(1e-9));
  CHECK(s.deformation_scatter_mm == Approx(0.01 * std::sqrt(0.045 / 3)).epsilon(1e-9));
  CHECK(s.fit_b_scatter == Approx(std::sqrt(0.045 / 3)).epsilon(1e-9));
  REQUIRE(s.fractions.size() == 3);  // the failed fraction enters nothing
  CHECK(s.fractions.front().dt_fraction == 0.2);  // coarsest first
  CHECK(s.fractions.front().force_N.mean == Approx(7.15));
  CHECK(s.fractions.front().force_N.change == Approx(0.15));
  CHECK(s.fractions.front().force_N.change_se == Approx(0.05));
  CHECK_FALSE(s.fractions.front().within);
  CHECK(s.fractions[1].force_N.change == Approx(0.08));
  CHECK(s.fractions[1].within);
  REQUIRE(s.converged_fraction);
  CHECK(*s.converged_fraction == 0.1);
  CHECK(s.points.front().dt_fraction == 0.4);  // listed, coarsest first
  CHECK(convergenceFromJson(toJson(s)).converged_fraction == s.converged_fraction);
  CHECK_THAT(markdown(s), Catch::Contains("blew up at step 10") && Catch::Contains("converged fraction"));

  // The same changes with no noise between steps: 0.08 N is then a bias the seeds tell for sure.
  std::vector<ConvergencePoint> exact = points;
  for (ConvergencePoint& p : exact)
    if (p.dt_fraction == 0.1) p = point(0.1, p.seed, 7.08 + 0.1 * (p.seed - 2.0), 0.0608 + 0.001 * (p.seed - 2.0), -1.45 + 0.1 * (p.seed - 2.0));
  CHECK_FALSE(summarize(exact, "test").fractions[1].within);
  CHECK_FALSE(summarize(exact, "test").converged_fraction);

  // The 0.1 fraction changed beyond one scatter: nothing coarser than the finest is converged, even
  // though 0.2 alone would be within.
  for (ConvergencePoint& p : points)
    if (p.dt_fraction == 0.1) p.force_mean_N += 0.12;
    else if (p.dt_fraction == 0.2) p.force_mean_N -= 0.1;
  const ConvergenceSummary off = summarize(points, "test");
  CHECK(off.fractions.front().within);
  CHECK_FALSE(off.converged_fraction);
  CHECK_THAT(markdown(off), Catch::Contains("not shown converged"));
}

TEST_CASE("one seed per fraction gives no convergence verdict", "[campaign]") {
  const ConvergenceSummary s = summarize({point(0.1, 1, 7.0, 0.06, -1.5), point(0.05, 1, 7.0, 0.06, -1.5)}, "test");
  CHECK(s.force_scatter_N == 0);
  CHECK_FALSE(s.converged_fraction);
}

TEST_CASE("the force at dt -> 0 is extrapolated from three halvings whose changes the seeds resolve, and only then", "[campaign]") {
  // F = 10 - 3 sqrt(f) N at every seed, with seed offsets the pairing removes: r = 2^-0.5, p = 0.5, F0 = 10.
  const auto points = [](double noise) {
    std::vector<ConvergencePoint> v;
    for (double f : {0.05, 0.025, 0.0125})
      for (std::uint64_t seed = 1; seed <= 2; ++seed) {
        const double jitter = f == 0.0125 ? 0 : noise * (seed == 1 ? 1 : -1);
        v.push_back(point(f, seed, 10 - 3 * std::sqrt(f) + 0.2 * static_cast<double>(seed) + jitter, 0.07, -1.5));
      }
    return v;
  };
  const ConvergenceSummary s = summarize(points(0), "test");
  REQUIRE(s.force_extrapolation);
  CHECK(s.force_extrapolation->halving_ratio == Approx(std::sqrt(0.5)).epsilon(1e-9));
  CHECK(s.force_extrapolation->order == Approx(0.5).epsilon(1e-9));
  CHECK(s.force_extrapolation->force_N == Approx(10 + 0.3).epsilon(1e-9));  // the seeds' mean offset is 0.3 N
  CHECK_THAT(markdown(s), Catch::Contains("an error going as dt^0.50"));
  CHECK(convergenceFromJson(toJson(s)).force_extrapolation->force_N == Approx(10.3).epsilon(1e-9));
  // Halvings that move the force by 0.20 and 0.14 N under standard errors of 0.3 N: no extrapolation.
  CHECK_FALSE(summarize(points(0.3), "test").force_extrapolation);
  // A change that grows at the finer halving has no limit to extrapolate to.
  std::vector<ConvergencePoint> growing = points(0);
  for (ConvergencePoint& p : growing)
    if (p.dt_fraction == 0.0125) p.force_mean_N += 1;
  CHECK_FALSE(summarize(growing, "test").force_extrapolation);
}

TEST_CASE("the step trend through all runs is the paired change when two fractions ran, and finds a line that one fluke row hides",
          "[campaign]") {
  // Two fractions: the line's change from finest to coarsest is the mean paired change, its
  // standard error the paired changes' (sd / sqrt(n)). Changes 0.1, 0.3, 0.2 N: mean 0.2, se 0.1 / sqrt(3).
  std::vector<ConvergencePoint> two;
  const double change[] = {0.1, 0.3, 0.2};
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    two.push_back(point(0.0125, seed, 7 + 0.5 * static_cast<double>(seed), 0.06, -1.4));
    two.push_back(point(0.025, seed, 7 + 0.5 * static_cast<double>(seed) + change[seed - 1], 0.06, -1.4));
  }
  const ConvergenceSummary paired = summarize(two, "test");
  REQUIRE(paired.trend);
  CHECK(paired.trend->runs == 6);
  CHECK(paired.trend->force_N.change_at_coarsest == Approx(paired.fractions.front().force_N.change).epsilon(1e-9));
  CHECK(paired.trend->force_N.change_at_coarsest_se == Approx(0.1 / std::sqrt(3.0)).epsilon(1e-9));
  CHECK(paired.trend->force_N.slope == Approx(0.2 / 0.0125).epsilon(1e-9));

  // Four halvings, no step effect, and one row 0.3 N off at every seed but one (a fluke shared by
  // the row): the paired rule rejects that row, and with it every coarser fraction; the line
  // through all runs says the step moves the force by less than its standard error.
  const double fractions[] = {0.025, 0.0125, 0.00625, 0.003125};
  const double jitter[4][4] = {{0.05, -0.05, 0.02, -0.02}, {0.3, 0.32, 0.28, -0.1}, {-0.03, 0.04, -0.05, 0.02}, {0, 0, 0, 0}};
  std::vector<ConvergencePoint> fluke;
  for (std::size_t i = 0; i < 4; ++i)
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
      const double level = 7 + 0.2 * static_cast<double>(seed);
      const double noise = jitter[i][seed - 1];
      fluke.push_back(point(fractions[i], seed, level + noise, 0.06 + 0.001 * noise, -1.4 + noise));
    }
  const ConvergenceSummary flukes = summarize(fluke, "test");
  CHECK(flukes.fractions.front().within);
  CHECK_FALSE(flukes.fractions[1].within);
  REQUIRE(flukes.converged_fraction);
  CHECK(*flukes.converged_fraction == 0.00625);
  REQUIRE(flukes.trend);
  CHECK(std::fabs(flukes.trend->force_N.change_at_coarsest) < flukes.trend->force_N.change_at_coarsest_se);

  // The same runs with a line of 20 N per unit fraction added: 0.4375 N between the ends, found
  // within two standard errors and resolved from zero.
  for (ConvergencePoint& p : fluke) p.force_mean_N += 20 * p.dt_fraction;
  const ConvergenceSummary line = summarize(fluke, "test");
  REQUIRE(line.trend);
  CHECK(std::fabs(line.trend->force_N.change_at_coarsest - 0.4375) < 2 * line.trend->force_N.change_at_coarsest_se);
  CHECK(line.trend->force_N.change_at_coarsest > 2 * line.trend->force_N.change_at_coarsest_se);
  CHECK(convergenceFromJson(toJson(line)).trend->force_N.slope == Approx(line.trend->force_N.slope).epsilon(1e-12));
  CHECK_THAT(markdown(line), Catch::Contains("A straight line in the step through all 16 runs of the 4 seeds"));

  // A seed with one run carries no slope: one seed per fraction gives no trend.
  CHECK_FALSE(summarize({point(0.1, 1, 7.0, 0.06, -1.5), point(0.05, 2, 7.0, 0.06, -1.5)}, "test").trend);
}
