// The verdict of the time-step convergence study (campaign/paper_convergence.hpp) on hand-made
// points: the seed scatter is the sample standard deviation of the seeded fraction's means, a
// fraction is converged when it and every finer one lie within two scatters of the finest, a
// failed run enters nothing, and the JSON round trip keeps the verdict.
#include "demfem/campaign/paper_convergence.hpp"

#include <catch2/catch.hpp>

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

TEST_CASE("the converged fraction is the coarsest within two seed scatters of the finest step", "[campaign]") {
  std::vector<ConvergencePoint> points{point(0.1, 1, 7.0, 0.060, -1.5), point(0.1, 2, 7.1, 0.061, -1.4), point(0.1, 3, 6.9, 0.059, -1.6),
                                       point(0.05, 1, 7.05, 0.0605, -1.45), point(0.2, 1, 7.15, 0.0598, -1.55)};
  ConvergencePoint failed = point(0.4, 1, 0, 0, 0);
  failed.failure = "builtin DEM blew up at step 10";
  points.push_back(failed);
  const ConvergenceSummary s = summarize(points, "test");
  CHECK(s.scatter_seeds == 3);
  CHECK(s.force_scatter_N == Approx(0.1).epsilon(1e-9));  // sd of 7.0, 7.1, 6.9
  CHECK(s.fit_b_scatter == Approx(0.1).epsilon(1e-9));
  REQUIRE(s.converged_fraction);
  CHECK(*s.converged_fraction == 0.2);  // |7.15 - 7.05| = 0.1 <= 0.2, the 0.4 run failed
  CHECK(s.points.front().dt_fraction == 0.4);  // listed, coarsest first
  CHECK(convergenceFromJson(toJson(s)).converged_fraction == s.converged_fraction);

  // The 0.2 run's force 0.3 N (three scatters) from the finest's: only 0.1 is converged.
  points[4].force_mean_N = 7.35;
  CHECK(summarize(points, "test").converged_fraction == 0.1);
  // The 0.1 run itself off by three scatters: nothing coarser than the finest is shown converged.
  points[0].force_mean_N = 7.35;
  points[1].force_mean_N = 7.45;
  points[2].force_mean_N = 7.25;
  CHECK_FALSE(summarize(points, "test").converged_fraction);
  CHECK_THAT(markdown(summarize(points, "test")), Catch::Contains("not shown converged") && Catch::Contains("blew up at step 10"));
}
