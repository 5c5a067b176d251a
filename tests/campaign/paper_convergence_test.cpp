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

TEST_CASE("the converged fraction is the coarsest whose seed-paired change is within one seed scatter", "[campaign]") {
  // Seeds 1-3 at three fractions; seed s's packing gives +0.1 (s - 2) N at every step, so the
  // scatter is 0.1 N and the pairing removes it from the changes.
  std::vector<ConvergencePoint> points;
  const auto add = [&](double fraction, double force, double deformation, double b) {
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      const double d = static_cast<double>(seed) - 2.0;
      points.push_back(point(fraction, seed, force + 0.1 * d, deformation + 0.001 * d, b + 0.1 * d));
    }
  };
  add(0.05, 7.0, 0.060, -1.5);
  add(0.1, 7.08, 0.0605, -1.45);  // 0.08 N, 0.0005 mm, 0.05 from the finest: within
  add(0.2, 7.15, 0.0598, -1.55);  // 0.15 N: beyond one scatter
  ConvergencePoint failed = point(0.4, 1, 0, 0, 0);
  failed.failure = "builtin DEM blew up at step 10";
  points.push_back(failed);
  const ConvergenceSummary s = summarize(points, "test");
  CHECK(s.scatter_seeds == 3);
  CHECK(s.force_scatter_N == Approx(0.1).epsilon(1e-9));
  CHECK(s.deformation_scatter_mm == Approx(0.001).epsilon(1e-9));
  CHECK(s.fit_b_scatter == Approx(0.1).epsilon(1e-9));
  REQUIRE(s.fractions.size() == 3);  // the failed fraction enters nothing
  CHECK(s.fractions.front().dt_fraction == 0.2);  // coarsest first
  CHECK(s.fractions.front().force_N.mean == Approx(7.15));
  CHECK(s.fractions.front().force_N.change == Approx(0.15));
  CHECK(s.fractions.front().force_N.change_se == Approx(0).margin(1e-12));  // the same offset for every seed
  CHECK_FALSE(s.fractions.front().within);
  CHECK(s.fractions[1].within);
  REQUIRE(s.converged_fraction);
  CHECK(*s.converged_fraction == 0.1);
  CHECK(s.points.front().dt_fraction == 0.4);  // listed, coarsest first
  CHECK(convergenceFromJson(toJson(s)).converged_fraction == s.converged_fraction);
  CHECK_THAT(markdown(s), Catch::Contains("blew up at step 10") && Catch::Contains("converged fraction"));

  // A change that differs between seeds: its standard error is sd / sqrt(3).
  points[3].force_mean_N += 0.03;  // 0.1 at seed 1
  points[5].force_mean_N -= 0.03;  // 0.1 at seed 3
  CHECK(summarize(points, "test").fractions[1].force_N.change_se == Approx(0.03 / std::sqrt(3.0)));

  // The 0.1 fraction changed by two scatters: nothing coarser than the finest is converged, even
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
