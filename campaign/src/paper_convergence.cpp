// The time-step convergence study's cases, verdict and table (campaign/paper_convergence.hpp).
#include "demfem/campaign/paper_convergence.hpp"

#include "demfem/study/study.hpp"

#include "paper_format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

namespace demfem::campaign {

namespace {

double sampleVariance(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  double mean = 0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  double ss = 0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return ss / static_cast<double>(v.size() - 1);
}

double meanOf(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? 0 : sum / static_cast<double>(v.size());
}

// The finished runs of one fraction, by seed.
using SeedRuns = std::map<std::uint64_t, const ConvergencePoint*>;

// `quantity` over the seeds of `runs`: mean, and the paired change against `finest`.
SeedAverage seedAverage(const SeedRuns& runs, const SeedRuns& finest, double ConvergencePoint::* quantity) {
  SeedAverage a;
  std::vector<double> values, changes;
  for (const auto& [seed, p] : runs) {
    values.push_back(p->*quantity);
    if (const auto f = finest.find(seed); f != finest.end()) changes.push_back(p->*quantity - f->second->*quantity);
  }
  a.mean = meanOf(values);
  a.change = meanOf(changes);
  a.change_se = std::sqrt(sampleVariance(changes) / static_cast<double>(std::max<std::size_t>(changes.size(), 1)));
  return a;
}

// Pooled sample standard deviation of `quantity` between the seeds of each fraction.
double pooledScatter(const std::map<double, SeedRuns>& by_fraction, double ConvergencePoint::* quantity) {
  double ss = 0, dof = 0;
  for (const auto& [fraction, runs] : by_fraction) {
    std::vector<double> v;
    for (const auto& [seed, p] : runs) v.push_back(p->*quantity);
    if (v.size() < 2) continue;
    ss += sampleVariance(v) * static_cast<double>(v.size() - 1);
    dof += static_cast<double>(v.size() - 1);
  }
  return dof > 0 ? std::sqrt(ss / dof) : 0;
}

// Richardson over the three finest fractions (see contract); `fractions` coarsest first.
std::optional<ForceExtrapolation> extrapolatedForce(const std::vector<FractionSummary>& fractions) {
  if (fractions.size() < 3) return std::nullopt;
  const FractionSummary& coarse = fractions[fractions.size() - 3];
  const FractionSummary& middle = fractions[fractions.size() - 2];
  const FractionSummary& finest = fractions.back();
  const auto halved = [](double coarser, double finer) { return std::fabs(coarser - 2 * finer) <= 1e-9 * coarser; };
  if (!halved(coarse.dt_fraction, middle.dt_fraction) || !halved(middle.dt_fraction, finest.dt_fraction)) return std::nullopt;
  const double c1 = coarse.force_N.change, c2 = middle.force_N.change;
  const double first_halving_se = std::hypot(coarse.force_N.change_se, middle.force_N.change_se);
  if (std::fabs(c2) <= 2 * middle.force_N.change_se || std::fabs(c1 - c2) <= 2 * first_halving_se) return std::nullopt;
  const double r = c2 / (c1 - c2);
  if (!(r > 0 && r < 1)) return std::nullopt;
  return ForceExtrapolation{r, std::log2(1 / r), finest.force_N.mean - c2 * r / (1 - r)};
}

// The runs of the seeds finished at two fractions or more, by seed.
std::map<std::uint64_t, std::vector<const ConvergencePoint*>> trendRuns(const std::vector<ConvergencePoint>& points) {
  std::map<std::uint64_t, std::vector<const ConvergencePoint*>> by_seed;
  for (const ConvergencePoint& p : points)
    if (p.failure.empty()) by_seed[p.seed].push_back(&p);
  std::erase_if(by_seed, [](const auto& entry) { return entry.second.size() < 2; });
  return by_seed;
}

// Least squares of `quantity` on the fraction, one level per seed (see contract); `span` =
// coarsest - finest fraction.
StepTrend stepTrend(const std::map<std::uint64_t, std::vector<const ConvergencePoint*>>& by_seed, double ConvergencePoint::* quantity,
                    double span, double dof) {
  std::vector<double> x, y;  // each seed's own mean removed
  for (const auto& [seed, runs] : by_seed) {
    double mean_x = 0, mean_y = 0;
    for (const ConvergencePoint* p : runs) mean_x += p->dt_fraction, mean_y += p->*quantity;
    mean_x /= static_cast<double>(runs.size()), mean_y /= static_cast<double>(runs.size());
    for (const ConvergencePoint* p : runs) x.push_back(p->dt_fraction - mean_x), y.push_back(p->*quantity - mean_y);
  }
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) sxx += x[i] * x[i], sxy += x[i] * y[i];
  StepTrend t;
  t.slope = sxy / sxx;
  double ss = 0;
  for (std::size_t i = 0; i < x.size(); ++i) ss += (y[i] - t.slope * x[i]) * (y[i] - t.slope * x[i]);
  t.slope_se = std::sqrt(ss / dof / sxx);
  t.change_at_coarsest = t.slope * span;
  t.change_at_coarsest_se = t.slope_se * span;
  return t;
}

std::optional<StepTrends> stepTrends(const std::vector<ConvergencePoint>& points, const std::vector<FractionSummary>& fractions) {
  const auto by_seed = trendRuns(points);
  StepTrends t;
  t.seeds = by_seed.size();
  for (const auto& [seed, runs] : by_seed) t.runs += runs.size();
  const double dof = static_cast<double>(t.runs) - static_cast<double>(t.seeds) - 1;
  if (fractions.size() < 2 || dof < 1) return std::nullopt;
  const double span = fractions.front().dt_fraction - fractions.back().dt_fraction;
  t.force_N = stepTrend(by_seed, &ConvergencePoint::force_mean_N, span, dof);
  t.deformation_mm = stepTrend(by_seed, &ConvergencePoint::deformation_mean_mm, span, dof);
  t.fit_b = stepTrend(by_seed, &ConvergencePoint::fit_b, span, dof);
  if (!std::isfinite(t.force_N.slope)) return std::nullopt;  // every seed ran one fraction only, twice
  return t;
}

}  // namespace

nlohmann::ordered_json reducedStudy(const nlohmann::ordered_json& base, double length_mm, double width_mm, double stroke_mm,
                                    double fraction, std::uint64_t seed) {
  nlohmann::ordered_json s = base;
  s["name"] = base.value("name", std::string("case")) + "_L" + formatNumber("%g", length_mm) + "_W" + formatNumber("%g", width_mm) + "_S" +
              formatNumber("%g", stroke_mm) + "_f" + formatNumber("%g", fraction) + "_seed" + std::to_string(seed);
  s["soil"]["bin"]["length_mm"] = length_mm;
  s["soil"]["bin"]["width_mm"] = width_mm;
  s["soil"]["deposition"]["seed"] = seed;
  s["tools"][0]["motion"]["stroke_mm"] = stroke_mm;
  s["tools"][0]["motion"].erase("center_x_mm");  // the bin's centre line of the cut bin
  nlohmann::ordered_json dem{{"backend", "builtin"}, {"criterion", "stiffest-spring"}, {"dt_fraction", fraction}};
  if (base.contains("dem") && base["dem"].contains("threads")) dem["threads"] = base["dem"]["threads"];
  s["dem"] = dem;
  study::parseStudy(s.dump(), s["name"].get<std::string>());  // throws StudyError naming the key
  return s;
}

ConvergenceSummary summarize(std::vector<ConvergencePoint> points, std::string reduced_case) {
  ConvergenceSummary s;
  s.reduced_case = std::move(reduced_case);
  std::sort(points.begin(), points.end(), [](const ConvergencePoint& a, const ConvergencePoint& b) {
    return a.dt_fraction != b.dt_fraction ? a.dt_fraction > b.dt_fraction : a.seed < b.seed;
  });
  s.points = std::move(points);
  std::map<double, SeedRuns> by_fraction;  // ascending: finest first
  std::set<std::uint64_t> seeds;
  for (const ConvergencePoint& p : s.points)
    if (p.failure.empty()) {
      by_fraction[p.dt_fraction][p.seed] = &p;
      seeds.insert(p.seed);
    }
  if (by_fraction.empty()) return s;
  s.scatter_seeds = seeds.size();
  s.force_scatter_N = pooledScatter(by_fraction, &ConvergencePoint::force_mean_N);
  s.deformation_scatter_mm = pooledScatter(by_fraction, &ConvergencePoint::deformation_mean_mm);
  s.fit_b_scatter = pooledScatter(by_fraction, &ConvergencePoint::fit_b);
  const SeedRuns& finest = by_fraction.begin()->second;
  const bool scattered = s.force_scatter_N > 0 && s.deformation_scatter_mm > 0 && s.fit_b_scatter > 0;
  bool all_finer_within = true;
  for (const auto& [fraction, runs] : by_fraction) {
    FractionSummary f;
    f.dt_fraction = fraction;
    f.seeds = runs.size();
    for (const auto& [seed, p] : runs) f.paired_seeds += finest.count(seed);
    f.force_N = seedAverage(runs, finest, &ConvergencePoint::force_mean_N);
    f.deformation_mm = seedAverage(runs, finest, &ConvergencePoint::deformation_mean_mm);
    f.fit_b = seedAverage(runs, finest, &ConvergencePoint::fit_b);
    const auto small = [](const SeedAverage& a, double scatter) {
      return std::fabs(a.change) <= scatter && std::fabs(a.change) <= 2 * a.change_se;
    };
    f.within = scattered && f.paired_seeds >= 2 && small(f.force_N, s.force_scatter_N) &&
               small(f.deformation_mm, s.deformation_scatter_mm) && small(f.fit_b, s.fit_b_scatter);
    const bool finest_fraction = fraction == by_fraction.begin()->first;
    if (!finest_fraction) {
      all_finer_within = all_finer_within && f.within;
      if (all_finer_within) s.converged_fraction = fraction;
    }
    s.fractions.insert(s.fractions.begin(), f);
  }
  s.force_extrapolation = extrapolatedForce(s.fractions);
  s.trend = stepTrends(s.points, s.fractions);
  return s;
}

nlohmann::json toJson(const ConvergenceSummary& s) {
  nlohmann::json points = nlohmann::json::array();
  for (const ConvergencePoint& p : s.points)
    points.push_back({{"dt_fraction", p.dt_fraction}, {"dt_s", p.dt_s}, {"seed", p.seed}, {"force_mean_N", p.force_mean_N},
                      {"force_std_N", p.force_std_N}, {"deformation_mean_mm", p.deformation_mean_mm},
                      {"deformation_std_mm", p.deformation_std_mm}, {"fit_b", p.fit_b}, {"fit_a", p.fit_a}, {"wall_time_s", p.wall_s},
                      {"failure", p.failure}});
  const auto trend = [](const StepTrend& t) {
    return nlohmann::json{{"slope_per_fraction", t.slope}, {"slope_se", t.slope_se}, {"change_at_coarsest", t.change_at_coarsest},
                          {"change_at_coarsest_se", t.change_at_coarsest_se}};
  };
  const auto average = [](const SeedAverage& a) { return nlohmann::json{{"mean", a.mean}, {"change", a.change}, {"change_se", a.change_se}}; };
  nlohmann::json fractions = nlohmann::json::array();
  for (const FractionSummary& f : s.fractions)
    fractions.push_back({{"dt_fraction", f.dt_fraction}, {"seeds", f.seeds}, {"paired_seeds", f.paired_seeds},
                         {"force_N", average(f.force_N)}, {"deformation_mm", average(f.deformation_mm)}, {"fit_b", average(f.fit_b)},
                         {"within_scatter", f.within}});
  return {{"reduced_case", s.reduced_case},
          {"points", points},
          {"scatter_seeds", s.scatter_seeds},
          {"force_scatter_N", s.force_scatter_N},
          {"deformation_scatter_mm", s.deformation_scatter_mm},
          {"fit_b_scatter", s.fit_b_scatter},
          {"fractions", fractions},
          {"converged_fraction", s.converged_fraction ? nlohmann::json(*s.converged_fraction) : nlohmann::json(nullptr)},
          {"force_extrapolation", s.force_extrapolation ? nlohmann::json{{"halving_ratio", s.force_extrapolation->halving_ratio},
                                                                          {"order", s.force_extrapolation->order},
                                                                          {"force_N", s.force_extrapolation->force_N}}
                                                        : nlohmann::json(nullptr)},
          {"trend", s.trend ? nlohmann::json{{"runs", s.trend->runs}, {"seeds", s.trend->seeds}, {"force_N", trend(s.trend->force_N)},
                                             {"deformation_mm", trend(s.trend->deformation_mm)}, {"fit_b", trend(s.trend->fit_b)}}
                            : nlohmann::json(nullptr)}};
}

ConvergenceSummary convergenceFromJson(const nlohmann::json& doc) {
  std::vector<ConvergencePoint> points;
  for (const nlohmann::json& p : doc.at("points"))
    points.push_back({p.at("dt_fraction").get<double>(), p.at("dt_s").get<double>(), p.at("seed").get<std::uint64_t>(),
                      p.at("force_mean_N").get<double>(), p.at("force_std_N").get<double>(), p.at("deformation_mean_mm").get<double>(),
                      p.at("deformation_std_mm").get<double>(), p.at("fit_b").get<double>(), p.at("fit_a").get<double>(),
                      p.at("wall_time_s").get<double>(), p.at("failure").get<std::string>()});
  return summarize(std::move(points), doc.at("reduced_case").get<std::string>());
}

std::string markdown(const ConvergenceSummary& s) {
  std::ostringstream md;
  md << "Reduced case: " << s.reduced_case << ". Window statistics and the FFT power-law fit of the deformation as in the case "
        "table below.\n\n| dt fraction | dt_DEM s | seed | force N (mean ± sd) | deformation mm (mean ± sd) | fit b | fit a | wall s |\n"
        "|---|---|---|---|---|---|---|---|\n";
  for (const ConvergencePoint& p : s.points) {
    if (!p.failure.empty()) {
      md << "| " << formatNumber("%g", p.dt_fraction) << " | " << formatNumber("%.3g", p.dt_s) << " | " << p.seed << " | not finished: "
         << p.failure.substr(0, p.failure.find(": particle")) << " | | | | " << formatNumber("%.0f", p.wall_s) << " |\n";
      continue;
    }
    md << "| " << formatNumber("%g", p.dt_fraction) << " | " << formatNumber("%.3g", p.dt_s) << " | " << p.seed << " | " << formatNumber("%.4g", p.force_mean_N)
       << " ± " << formatNumber("%.2g", p.force_std_N) << " | " << formatNumber("%.4g", p.deformation_mean_mm) << " ± " << formatNumber("%.2g", p.deformation_std_mm)
       << " | " << formatNumber("%.3f", p.fit_b) << " | " << formatNumber("%.3g", p.fit_a) << " | " << formatNumber("%.0f", p.wall_s) << " |\n";
  }
  md << "\nPer fraction, over its seeds; the change is against the finest step, seed by seed through the same packing (mean ± "
        "standard error). Seed scatter, the spread of one run between seeds ("
     << s.scatter_seeds << " deposition seeds, pooled over the fractions): force " << formatNumber("%.3g", s.force_scatter_N)
     << " N, deformation " << formatNumber("%.3g", s.deformation_scatter_mm) << " mm, fit b " << formatNumber("%.3f", s.fit_b_scatter)
     << ".\n\n| dt fraction | seeds | force N | force change N | deformation mm | deformation change mm | fit b | fit b change | "
        "converged |\n|---|---|---|---|---|---|---|---|---|\n";
  const auto change = [](const SeedAverage& a, const char* format) {
    return formatNumber(format, a.change) + " ± " + formatNumber("%.2g", a.change_se);
  };
  const double finest_force_N = s.fractions.empty() ? 0 : s.fractions.back().force_N.mean;
  for (const FractionSummary& f : s.fractions) {
    const bool finest = &f == &s.fractions.back();
    md << "| " << formatNumber("%g", f.dt_fraction) << " | " << f.seeds << " | " << formatNumber("%.4g", f.force_N.mean) << " | "
       << (finest ? "(finest)" : change(f.force_N, "%+.3g") + " (" + formatNumber("%+.1f", 100 * f.force_N.change / finest_force_N) + " %)")
       << " | " << formatNumber("%.4g", f.deformation_mm.mean) << " | " << (finest ? "(finest)" : change(f.deformation_mm, "%+.3g")) << " | "
       << formatNumber("%.3f", f.fit_b.mean) << " | " << (finest ? "(finest)" : change(f.fit_b, "%+.3f")) << " | "
       << (finest ? "" : f.within ? "yes" : "no") << " |\n";
  }
  md << '\n';
  if (s.converged_fraction)
    md << "Every fraction up to " << formatNumber("%g", *s.converged_fraction)
       << " changes force, deformation and fit exponent against the finest step by at most one seed scatter and by no more "
          "than two standard errors (no bias the seeds can tell): that is the converged fraction.";
  else
    md << "No coarser fraction changes force, deformation and fit exponent against the finest step by at most one seed scatter "
          "and two standard errors (over at least two seeds): the step is not shown converged at these fractions.";
  md << '\n';
  if (const auto& x = s.force_extrapolation) {
    md << "\nThe force's change per halving of the step shrinks by " << formatNumber("%.2f", x->halving_ratio)
       << " from one halving to the next, an error going as dt^" << formatNumber("%.2f", x->order)
       << "; extrapolated that way (Richardson), the force at dt -> 0 is " << formatNumber("%.3g", x->force_N) << " N, against which";
    for (const FractionSummary& f : s.fractions)
      md << (&f == &s.fractions.front() ? " " : ", ") << formatNumber("%g", f.dt_fraction) << " is "
         << formatNumber("%+.1f", 100 * (f.force_N.mean / x->force_N - 1)) << " %";
    md << ".\n";
  }
  if (const auto& t = s.trend) {
    const auto line = [](const StepTrend& x, const char* format) {
      return formatNumber(format, x.change_at_coarsest) + " ± " + formatNumber("%.2g", x.change_at_coarsest_se);
    };
    const double finest_force_N = s.fractions.back().force_N.mean;
    md << "\nA straight line in the step through all " << t->runs << " runs of the " << t->seeds
       << " seeds, each seed's own level removed (least squares, ± its standard error), moves from the finest fraction to "
       << formatNumber("%g", s.fractions.front().dt_fraction) << " the force by " << line(t->force_N, "%+.3g") << " N ("
       << formatNumber("%+.1f", 100 * t->force_N.change_at_coarsest / finest_force_N) << " %), the deformation by "
       << line(t->deformation_mm, "%+.3g") << " mm and the fit exponent b by " << line(t->fit_b, "%+.3f") << ".\n";
  }
  return md.str();
}

}  // namespace demfem::campaign
