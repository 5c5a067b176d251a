#include "demfem/analysis/cone_penetration.hpp"

#include "demfem/analysis/recording.hpp"
#include "table_io.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace demfem::analysis {

namespace {

namespace fs = std::filesystem;
using detail::formatNumber;

void checkProfile(const CprProfile& p) {
  if (p.depth_m.size() < 2 || p.depth_m.size() != p.cpr_Pa.size())
    throw InputError("CPR profile '" + p.label + "': needs at least two (depth, CPR) samples");
  for (std::size_t i = 1; i < p.depth_m.size(); ++i)
    if (!(p.depth_m[i] > p.depth_m[i - 1]))
      throw InputError("CPR profile '" + p.label + "': depth " + formatNumber(p.depth_m[i] * 1e3) +
                       " mm does not increase (previous " + formatNumber(p.depth_m[i - 1] * 1e3) + " mm)");
}

// The profile at grid depth d: mean of the samples within +-step/2 when that bin lies inside the
// profile's depth range and holds samples, else the linear interpolation.
double onGrid(const CprProfile& p, double d, double step) {
  const auto lo = std::lower_bound(p.depth_m.begin(), p.depth_m.end(), d - step / 2);
  const auto hi = std::lower_bound(p.depth_m.begin(), p.depth_m.end(), d + step / 2);
  if (hi > lo && d - step / 2 >= p.depth_m.front() && d + step / 2 <= p.depth_m.back()) {
    const auto first = p.cpr_Pa.begin() + (lo - p.depth_m.begin()), last = p.cpr_Pa.begin() + (hi - p.depth_m.begin());
    return std::accumulate(first, last, 0.0) / static_cast<double>(last - first);
  }
  const auto k = static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(lo - p.depth_m.begin(), 1, static_cast<std::ptrdiff_t>(p.depth_m.size()) - 1));
  const double w = (d - p.depth_m[k - 1]) / (p.depth_m[k] - p.depth_m[k - 1]);
  return p.cpr_Pa[k - 1] + w * (p.cpr_Pa[k] - p.cpr_Pa[k - 1]);
}

}  // namespace

double coneResistance_Pa(double vertical_force_N, double projected_area_m2) { return vertical_force_N / projected_area_m2; }

CprSummary summarize(const std::string& soil, const std::vector<CprProfile>& profiles, double step_m) {
  if (profiles.size() < 2) throw InputError(soil + ": CPR statistics need at least two profiles, got " + std::to_string(profiles.size()));
  if (!(step_m > 0)) throw InputError(soil + ": the CPR depth step must be > 0");
  double deepest = INFINITY, shallowest = 0;
  for (const auto& p : profiles) {
    checkProfile(p);
    deepest = std::min(deepest, p.depth_m.back());
    shallowest = std::max(shallowest, p.depth_m.front());
  }
  CprSummary s;
  s.soil = soil;
  s.step_m = step_m;
  s.profiles = profiles.size();
  s.profile_Pa.resize(profiles.size());
  for (long k = std::max(1L, std::lround(std::ceil(shallowest / step_m - 1e-9))); k * step_m <= deepest + 1e-12; ++k) {
    const double d = static_cast<double>(k) * step_m;
    double sum = 0;
    for (std::size_t i = 0; i < profiles.size(); ++i) {
      s.profile_Pa[i].push_back(onGrid(profiles[i], d, step_m));
      sum += s.profile_Pa[i].back();
    }
    const double mean = sum / static_cast<double>(profiles.size());
    double sq = 0;
    for (const auto& p : s.profile_Pa) sq += (p.back() - mean) * (p.back() - mean);
    s.depth_m.push_back(d);
    s.mean_Pa.push_back(mean);
    s.std_Pa.push_back(std::sqrt(sq / static_cast<double>(profiles.size() - 1)));
  }
  if (s.depth_m.empty())
    throw InputError(soil + ": the CPR profiles share no depth range of one step (" + formatNumber(step_m * 1e3) + " mm)");
  double ratio_sum = 0;
  std::size_t used = 0;
  for (std::size_t k = 0; k < s.depth_m.size(); ++k)
    if (s.mean_Pa[k] > 0) {
      ratio_sum += s.std_Pa[k] / s.mean_Pa[k];
      ++used;
    }
  s.mean_deviation = used ? ratio_sum / static_cast<double>(used) : 0.0;
  return s;
}

CprComparison compare(const CprSummary& simulated, const CprSummary& measured) {
  if (std::fabs(simulated.step_m - measured.step_m) > 1e-12)
    throw InputError("CPR comparison: " + simulated.soil + " and " + measured.soil + " use different depth steps");
  CprComparison c{simulated.soil, measured.soil, 0, 0, 0};
  std::size_t within = 0;
  double rel = 0;
  for (std::size_t i = 0; i < simulated.depth_m.size(); ++i) {
    const long key = std::lround(simulated.depth_m[i] / simulated.step_m);
    for (std::size_t j = 0; j < measured.depth_m.size(); ++j) {
      if (std::lround(measured.depth_m[j] / measured.step_m) != key || !(measured.mean_Pa[j] > 0)) continue;
      ++c.depths;
      if (std::fabs(simulated.mean_Pa[i] - measured.mean_Pa[j]) <= measured.std_Pa[j]) ++within;
      rel += (simulated.mean_Pa[i] - measured.mean_Pa[j]) / measured.mean_Pa[j];
    }
  }
  if (c.depths == 0) throw InputError("CPR comparison: " + simulated.soil + " and " + measured.soil + " share no depth");
  c.within_measured_band = static_cast<double>(within) / static_cast<double>(c.depths);
  c.mean_relative_difference = rel / static_cast<double>(c.depths);
  return c;
}

MeasuredProfile readMeasuredProfile(const fs::path& csv) {
  const fs::path sidecar_path = fs::path(csv).replace_extension(".json");
  const detail::Sidecar sidecar(sidecar_path);
  if (sidecar.text("kind") != "cone-penetration")
    sidecar.fail("kind", "expected \"cone-penetration\" (a measured CPR profile)");
  MeasuredProfile out;
  out.soil = sidecar.text("soil");
  out.repeat = sidecar.repeat(std::nullopt);
  out.area_m2 = sidecar.positive("area_mm2") * 1e-6;
  const detail::Table table = detail::readTable(csv);
  const std::size_t depth = detail::findColumn(table, csv, "depth_mm", true), cpr = detail::findColumn(table, csv, "CPR_kPa", true);
  out.profile.label = "repeat " + std::to_string(out.repeat);
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    const double d = detail::parseCell(table.rows[r][depth], csv, table.row_line[r], depth, "depth_mm");
    const double p = detail::parseCell(table.rows[r][cpr], csv, table.row_line[r], cpr, "CPR_kPa");
    if (d < 0 || (!out.profile.depth_m.empty() && !(d * 1e-3 > out.profile.depth_m.back())))
      throw InputError(csv.string() + ":" + std::to_string(table.row_line[r]) + ":" + std::to_string(depth + 1) +
                       ": column 'depth_mm': depths must be >= 0 and increasing, got " + table.rows[r][depth]);
    out.profile.depth_m.push_back(d * 1e-3);
    out.profile.cpr_Pa.push_back(p * 1e3);
  }
  if (out.profile.depth_m.size() < 2) throw InputError(csv.string() + ": needs at least two rows (depth_mm, CPR_kPa)");
  return out;
}

}  // namespace demfem::analysis
