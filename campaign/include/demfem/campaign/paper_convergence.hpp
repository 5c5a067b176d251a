// The time-step convergence study of docs/paper-reproduction.md ("Time step"): one reduced paper
// bin run at halved fractions of the stiffest spring's critical step and at several deposition
// seeds, each run's window statistics and FFT fit (evaluateCampaignRun), and whether a fraction's
// numbers lie within the seed scatter of the finest step's.
//
// Contract
// - reducedStudy(base, ...): `base` (a paper case, study file JSON) with the bin cut to
//   length x width (fill height, layers, particles and contact data kept), the stroke cut, the
//   DEM step at `fraction` of the stiffest spring (dem.criterion stiffest-spring) and the
//   deposition seed set; the name says all three. Throws study::StudyError if that is invalid.
// - summarize(points): points with a failure are listed but enter nothing else. Every fraction
//   is meant to run at the same deposition seeds, each seed's fractions dragging through that seed's
//   one packing, so that a fraction's change against the finest step is measured pairwise (common
//   random numbers). Per fraction: the means over its seeds of force mean, deformation mean and fit
//   exponent b, and the change against the finest fraction, the mean over the seeds both finished
//   of (this - finest), with its standard error (sample sd / sqrt(n); 0 with one seed). The seed
//   scatter is the pooled sample standard deviation of those three numbers between the seeds of
//   each fraction (0 without a fraction of two seeds): the spread a single run shows. A fraction is
//   within (`FractionSummary::within`) when each of its three changes is at most one scatter (the
//   step moves the result less than a new packing does) and at most two standard errors (no bias
//   the seeds can tell), over at least two paired seeds; `converged_fraction` is the largest
//   fraction coarser than the finest that is, and every finer one too (none without a scatter).
//   With many seeds the second condition asks for a bias below what they resolve: it is
//   conservative, never lax.
// - Extrapolation (force only): over the three finest fractions when each is half the one before,
//   from the paired changes c1 (coarsest of the three) and c2 against the finest: the change per
//   halving shrinks by r = c2 / (c1 - c2). When 0 < r < 1 and both halvings' changes exceed two
//   standard errors (c2's; c1 - c2 taken with sqrt(se1^2 + se2^2)), the force is modelled as
//   F(dt) = F0 + C dt^p (Richardson): order p = log2(1 / r), F0 = finest mean - c2 r / (1 - r).
//   Otherwise none: a change the seeds cannot resolve, or one that does not shrink, says nothing of
//   the limit.
// - Trend: the least-squares slope of each of the three numbers against the step (per unit of
//   dt fraction) through every finished run of the seeds finished at two fractions or more, each
//   seed's own mean removed (one level per packing: the pairing of the changes, extended to all
//   fractions at once), with its standard error from the residuals (runs - seeds - 1 degrees of
//   freedom; none with fewer than one). `change_at_coarsest` = slope x (coarsest - finest
//   fraction): what a straight line through all the runs says the step moves between the two ends.
//   It pools every run, so a fraction whose paired change is a fluke of few seeds (a step bias
//   grows with the step, a fluke need not) does not decide it alone; the verdict above is not
//   changed by it.
// - markdown(): the table and the verdict, for the bench's output and the report.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace demfem::campaign {

struct ConvergencePoint {
  double dt_fraction = 0, dt_s = 0;
  std::uint64_t seed = 1;
  double force_mean_N = 0, force_std_N = 0, deformation_mean_mm = 0, deformation_std_mm = 0;
  double fit_b = 0, fit_a = 0;
  double wall_s = 0;
  std::string failure;  // empty: the run finished; else why not (a blow-up: the step is unstable)
};

// One number over a fraction's seeds: its mean, and its change against the finest fraction's
// (paired by seed) with that change's standard error.
struct SeedAverage {
  double mean = 0, change = 0, change_se = 0;
};

struct FractionSummary {
  double dt_fraction = 0;
  std::size_t seeds = 0, paired_seeds = 0;  // finished runs; those also finished at the finest step
  SeedAverage force_N, deformation_mm, fit_b;
  bool within = false;
};

// The force at dt -> 0 from the three finest fractions (see contract).
struct ForceExtrapolation {
  double halving_ratio = 0;  // r: the change of the finer halving over the coarser one's
  double order = 0;          // p of the error C dt^p
  double force_N = 0;        // F0
};

// One number's straight line in the step over all runs (see contract).
struct StepTrend {
  double slope = 0, slope_se = 0;  // per unit of dt fraction
  double change_at_coarsest = 0, change_at_coarsest_se = 0;
};

struct StepTrends {
  std::size_t runs = 0, seeds = 0;
  StepTrend force_N, deformation_mm, fit_b;
};

struct ConvergenceSummary {
  std::vector<ConvergencePoint> points;
  std::vector<FractionSummary> fractions;  // coarsest first
  double force_scatter_N = 0, deformation_scatter_mm = 0, fit_b_scatter = 0;
  std::size_t scatter_seeds = 0;  // distinct seeds among the finished runs
  std::optional<double> converged_fraction;
  std::optional<ForceExtrapolation> force_extrapolation;
  std::optional<StepTrends> trend;
  std::string reduced_case;  // what was run (bin, stroke, particles), for the table's caption
};

nlohmann::ordered_json reducedStudy(const nlohmann::ordered_json& base, double length_mm, double width_mm, double stroke_mm,
                                    double fraction, std::uint64_t seed);

ConvergenceSummary summarize(std::vector<ConvergencePoint> points, std::string reduced_case);

nlohmann::json toJson(const ConvergenceSummary& s);
ConvergenceSummary convergenceFromJson(const nlohmann::json& doc);  // throws nlohmann::json::exception
std::string markdown(const ConvergenceSummary& s);

}  // namespace demfem::campaign
