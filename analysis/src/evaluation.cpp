#include "demfem/analysis/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

namespace demfem::analysis {
namespace {

std::string fmt(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// First time the signal reaches `level`, linearly interpolated between the bracketing samples.
// Returns nullopt when it never does.
std::optional<double> firstCrossing(const std::vector<double>& t, const std::vector<double>& y, double level) {
  for (std::size_t i = 1; i < y.size(); ++i) {
    if (y[i] >= level) {
      if (y[i - 1] >= level) return t[i - 1];
      return t[i - 1] + (level - y[i - 1]) / (y[i] - y[i - 1]) * (t[i] - t[i - 1]);
    }
  }
  return std::nullopt;
}

}  // namespace

double interpolate(const std::vector<double>& x, const std::vector<double>& y, double xq) {
  if (xq <= x.front()) return y.front();
  if (xq >= x.back()) return y.back();
  const auto upper = std::upper_bound(x.begin(), x.end(), xq);
  const std::size_t i = static_cast<std::size_t>(upper - x.begin());
  const double span = x[i] - x[i - 1];
  if (span <= 0.0) return y[i];
  return y[i - 1] + (xq - x[i - 1]) / span * (y[i] - y[i - 1]);
}

SignalStatistics meanAndStdDev(const std::vector<double>& values) {
  SignalStatistics stats;
  stats.samples = values.size();
  stats.mean = std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(values.size());
  if (values.size() > 1) {
    double sum_sq = 0.0;
    for (double v : values) sum_sq += (v - stats.mean) * (v - stats.mean);
    stats.std_dev = std::sqrt(sum_sq / static_cast<double>(values.size() - 1));
  }
  return stats;
}

SignalStatistics windowStatistics(const std::vector<double>& x, const std::vector<double>& values, double window_begin,
                                  double window_end) {
  std::vector<double> inside;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (x[i] >= window_begin && x[i] <= window_end) inside.push_back(values[i]);
  if (inside.empty()) return {};
  return meanAndStdDev(inside);
}

EvaluatedRun evaluateSoilBinRun(const Recording& rec, const EvaluationSettings& settings) {
  if (rec.key.kind != CaseKind::SoilBin)
    throw InputError(rec.sidecar_path.string() + ": not a soil-bin run (the sidecar gives mass_kg, not depth_mm)");
  EvaluatedRun run;
  run.key = rec.key;
  run.repeat = rec.repeat;
  run.source = rec.csv_path;
  const std::string file = rec.csv_path.string();

  if (rec.format == RecordingFormat::Calibrated) {
    run.curve.time_s = rec.time_s;
    run.curve.displacement_mm = rec.displacement_mm;
    run.curve.force_N = rec.force;
    run.curve.deformation_mm = rec.deformation;
    run.curve.tilt_deg = rec.tilt_deg;
    run.start_time_s = rec.time_s.front();
    run.end_time_s = rec.time_s.back();
  } else {
    run.section_2_3_applied = true;
    const std::size_t n = rec.size();
    std::vector<double> force(n), deformation(n);
    for (std::size_t i = 0; i < n; ++i) {
      force[i] = rec.force[i] * rec.force_factor_N_per_unit;                   // step 1
      deformation[i] = rec.deformation[i] * rec.deformation_factor_mm_per_unit;
    }
    // Step 2: initial deformation value.
    std::vector<double> baseline;
    for (std::size_t i = 0; i < n && (baseline.empty() || rec.time_s[i] <= rec.time_s.front() + settings.baseline_duration_s); ++i)
      baseline.push_back(deformation[i]);
    const SignalStatistics initial = meanAndStdDev(baseline);
    const double d0 = initial.mean;
    // Step 3: line through the 10 % and 20 % points, intersected with d = d0.
    const double d_max = *std::max_element(deformation.begin(), deformation.end());
    if (!(d_max - d0 > std::max(3.0 * initial.std_dev, 1e-9 * std::abs(d0))))
      throw InputError(file + ": column 'deformation': never rises clearly above its initial value " + fmt(d0) + " mm (maximum " +
                       fmt(d_max) + " mm, baseline noise " + fmt(initial.std_dev) + " mm): no start can be found (Section 2.3)");
    const double level_low = d0 + settings.start_low_fraction * (d_max - d0);
    const double level_high = d0 + settings.start_high_fraction * (d_max - d0);
    const auto crossing_low = firstCrossing(rec.time_s, deformation, level_low);
    const auto crossing_high = firstCrossing(rec.time_s, deformation, level_high);
    if (!crossing_low || !crossing_high)
      throw InputError(file + ":" + std::to_string(rec.line.front()) + ": column 'deformation': its maximum " + fmt(d_max) +
                       " mm is the first sample: no rise to find the start on (Section 2.3)");
    const double t_low = *crossing_low;
    const double t_high = *crossing_high;
    const double t_start = t_high > t_low ? t_low - (level_low - d0) * (t_high - t_low) / (level_high - level_low) : t_low;
    // Step 4: end at the maximum of the end signal after the start.
    const std::vector<double>& end_signal = settings.end_signal == EndSignal::Force ? force : deformation;
    const std::size_t first_kept =
        static_cast<std::size_t>(std::lower_bound(rec.time_s.begin(), rec.time_s.end(), t_start) - rec.time_s.begin());
    const std::size_t last_kept =
        static_cast<std::size_t>(std::max_element(end_signal.begin() + static_cast<std::ptrdiff_t>(first_kept), end_signal.end()) - end_signal.begin());
    if (last_kept <= first_kept)
      throw InputError(file + ": the maximum of column '" + std::string(settings.end_signal == EndSignal::Force ? "force" : "deformation") +
                       "' (line " + std::to_string(rec.line[last_kept]) + ") is reached at the start (t = " + fmt(t_start) +
                       " s): no stroke to evaluate (Section 2.3)");
    const double t_end = rec.time_s[last_kept];
    // Step 5: displacement divided evenly between the start and the end.
    for (std::size_t i = first_kept; i <= last_kept; ++i) {
      run.curve.time_s.push_back(rec.time_s[i] - t_start);
      run.curve.displacement_mm.push_back(rec.stroke_mm * (rec.time_s[i] - t_start) / (t_end - t_start));
      run.curve.force_N.push_back(force[i]);
      run.curve.deformation_mm.push_back(deformation[i] - d0);
    }
    run.start_time_s = t_start;
    run.end_time_s = t_end;
    run.initial_deformation_mm = d0;
    run.max_deformation_mm = d_max;
  }

  const auto& x = run.curve.displacement_mm;
  const auto [x_min, x_max] = std::minmax_element(x.begin(), x.end());
  const double slack = 0.01 * (settings.window_end_mm - settings.window_begin_mm);
  if (*x_min > settings.window_begin_mm + slack || *x_max < settings.window_end_mm - slack)
    throw InputError(file + ": the run covers " + fmt(*x_min) + "-" + fmt(*x_max) + " mm of tool displacement but the statistics window is " +
                     fmt(settings.window_begin_mm) + "-" + fmt(settings.window_end_mm) +
                     " mm (a run that stopped early; choose a window it covers with --window-begin-mm/--window-end-mm)");
  run.window.force_N = windowStatistics(x, run.curve.force_N, settings.window_begin_mm, settings.window_end_mm);
  run.window.deformation_mm = windowStatistics(x, run.curve.deformation_mm, settings.window_begin_mm, settings.window_end_mm);
  if (run.window.force_N.samples < settings.min_window_samples)
    throw InputError(file + ": only " + std::to_string(run.window.force_N.samples) + " samples in the window " + fmt(settings.window_begin_mm) +
                     "-" + fmt(settings.window_end_mm) + " mm (need " + std::to_string(settings.min_window_samples) +
                     "): the recording is too coarse for the window");
  if (!run.curve.tilt_deg.empty())
    run.window.tilt_deg = windowStatistics(x, run.curve.tilt_deg, settings.window_begin_mm, settings.window_end_mm);
  return run;
}

PooledCase poolRepeats(const std::vector<const EvaluatedRun*>& runs, const EvaluationSettings& settings) {
  PooledCase pooled;
  pooled.key = runs.front()->key;
  std::vector<double> force_means, deformation_means, force_all, deformation_all;
  for (const EvaluatedRun* run : runs) {
    pooled.repeats.push_back(run->repeat);
    force_means.push_back(run->window.force_N.mean);
    deformation_means.push_back(run->window.deformation_mm.mean);
    const auto& c = run->curve;
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (c.displacement_mm[i] < settings.window_begin_mm || c.displacement_mm[i] > settings.window_end_mm) continue;
      force_all.push_back(c.force_N[i]);
      deformation_all.push_back(c.deformation_mm[i]);
    }
  }
  const auto force_between = meanAndStdDev(force_means);
  const auto deformation_between = meanAndStdDev(deformation_means);
  pooled.force_mean_N = force_between.mean;
  pooled.deformation_mean_mm = deformation_between.mean;
  if (runs.size() > 1) {
    pooled.force_between_repeats_std_N = force_between.std_dev;
    pooled.deformation_between_repeats_std_mm = deformation_between.std_dev;
  }
  pooled.force_std_N = meanAndStdDev(force_all).std_dev;
  pooled.deformation_std_mm = meanAndStdDev(deformation_all).std_dev;

  // Mean curve on a common grid: the overlap of all runs, as many points as the sparsest run.
  double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
  std::size_t points = std::numeric_limits<std::size_t>::max();
  for (const EvaluatedRun* run : runs) {
    lo = std::max(lo, run->curve.displacement_mm.front());
    hi = std::min(hi, run->curve.displacement_mm.back());
    points = std::min(points, run->curve.size());
  }
  if (hi > lo && points >= 2) {
    auto& mean = pooled.mean_curve;
    const double count = static_cast<double>(runs.size());
    for (std::size_t k = 0; k < points; ++k) {
      const double x = lo + (hi - lo) * static_cast<double>(k) / static_cast<double>(points - 1);
      double t = 0, f = 0, d = 0;
      for (const EvaluatedRun* run : runs) {
        t += interpolate(run->curve.displacement_mm, run->curve.time_s, x);
        f += interpolate(run->curve.displacement_mm, run->curve.force_N, x);
        d += interpolate(run->curve.displacement_mm, run->curve.deformation_mm, x);
      }
      mean.displacement_mm.push_back(x);
      mean.time_s.push_back(t / count);
      mean.force_N.push_back(f / count);
      mean.deformation_mm.push_back(d / count);
    }
  }
  return pooled;
}

}  // namespace demfem::analysis
