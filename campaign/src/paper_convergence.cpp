// The time-step convergence study's cases, verdict and table (campaign/paper_convergence.hpp).
#include "demfem/campaign/paper_convergence.hpp"

#include "demfem/study/study.hpp"

#include "paper_format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

namespace demfem::campaign {

namespace {

double sampleStd(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  double mean = 0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  double ss = 0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / static_cast<double>(v.size() - 1));
}

const ConvergencePoint* seedOne(const std::vector<ConvergencePoint>& points, double fraction) {
  for (const ConvergencePoint& p : points)
    if (p.dt_fraction == fraction && p.seed == 1 && p.failure.empty()) return &p;
  return nullptr;
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
  std::map<double, std::vector<const ConvergencePoint*>> by_fraction;
  for (const ConvergencePoint& p : s.points)
    if (p.failure.empty()) by_fraction[p.dt_fraction].push_back(&p);
  if (by_fraction.empty()) return s;
  const auto most = std::max_element(by_fraction.begin(), by_fraction.end(),
                                     [](const auto& a, const auto& b) { return a.second.size() < b.second.size(); });
  std::vector<double> f, d, b;
  for (const ConvergencePoint* p : most->second) {
    f.push_back(p->force_mean_N);
    d.push_back(p->deformation_mean_mm);
    b.push_back(p->fit_b);
  }
  s.scatter_seeds = most->second.size();
  s.force_scatter_N = sampleStd(f);
  s.deformation_scatter_mm = sampleStd(d);
  s.fit_b_scatter = sampleStd(b);
  const double finest = by_fraction.begin()->first;
  const ConvergencePoint* ref = seedOne(s.points, finest);
  if (!ref || s.scatter_seeds < 2) return s;
  bool all_finer_within = true;
  for (const auto& [fraction, list] : by_fraction) {  // ascending: finest first
    const ConvergencePoint* p = seedOne(s.points, fraction);
    if (!p) continue;
    const bool within = std::fabs(p->force_mean_N - ref->force_mean_N) <= 2 * s.force_scatter_N &&
                        std::fabs(p->deformation_mean_mm - ref->deformation_mean_mm) <= 2 * s.deformation_scatter_mm &&
                        std::fabs(p->fit_b - ref->fit_b) <= 2 * s.fit_b_scatter;
    if (within) s.within_scatter.push_back(fraction);
    all_finer_within = all_finer_within && within;
    if (all_finer_within && fraction != finest) s.converged_fraction = fraction;
  }
  return s;
}

nlohmann::json toJson(const ConvergenceSummary& s) {
  nlohmann::json points = nlohmann::json::array();
  for (const ConvergencePoint& p : s.points)
    points.push_back({{"dt_fraction", p.dt_fraction}, {"dt_s", p.dt_s}, {"seed", p.seed}, {"force_mean_N", p.force_mean_N},
                      {"force_std_N", p.force_std_N}, {"deformation_mean_mm", p.deformation_mean_mm},
                      {"deformation_std_mm", p.deformation_std_mm}, {"fit_b", p.fit_b}, {"fit_a", p.fit_a}, {"wall_time_s", p.wall_s},
                      {"failure", p.failure}});
  return {{"reduced_case", s.reduced_case},
          {"points", points},
          {"scatter_seeds", s.scatter_seeds},
          {"force_scatter_N", s.force_scatter_N},
          {"deformation_scatter_mm", s.deformation_scatter_mm},
          {"fit_b_scatter", s.fit_b_scatter},
          {"within_scatter_fractions", s.within_scatter},
          {"converged_fraction", s.converged_fraction ? nlohmann::json(*s.converged_fraction) : nlohmann::json(nullptr)}};
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
  md << "\nSeed scatter (" << s.scatter_seeds << " deposition seeds): force " << formatNumber("%.3g", s.force_scatter_N) << " N, deformation "
     << formatNumber("%.3g", s.deformation_scatter_mm) << " mm, fit b " << formatNumber("%.3f", s.fit_b_scatter) << ". ";
  if (s.converged_fraction)
    md << "Every fraction up to " << formatNumber("%g", *s.converged_fraction)
       << " gives the finest step's numbers within two seed scatters: that is the converged fraction.";
  else
    md << "No coarser fraction gives the finest step's numbers within two seed scatters: the step is not shown converged at "
          "these fractions.";
  // The change of the seed-1 force and deformation means at each halving (fractions descending).
  const ConvergencePoint* previous = nullptr;
  for (const ConvergencePoint& p : s.points) {
    if (p.seed != 1 || !p.failure.empty()) continue;
    if (previous)
      md << " From " << formatNumber("%g", previous->dt_fraction) << " to " << formatNumber("%g", p.dt_fraction) << ": force "
         << formatNumber("%+.1f", 100 * (p.force_mean_N / previous->force_mean_N - 1)) << " %, deformation "
         << formatNumber("%+.1f", 100 * (p.deformation_mean_mm / previous->deformation_mean_mm - 1)) << " %.";
    previous = &p;
  }
  md << '\n';
  return md.str();
}

}  // namespace demfem::campaign
