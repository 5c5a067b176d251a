#include "demfem/cli/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>

namespace demfem::cli {

using namespace std::chrono_literals;

Progress::Progress(std::string phase, bool enabled)
    : Progress(std::move(phase), enabled, std::cerr, isatty(STDERR_FILENO) == 1, 5s, 1s) {}

Progress::Progress(std::string phase, bool enabled, std::ostream& out, bool terminal, Clock::duration interval,
                   Clock::duration delay)
    : phase_(std::move(phase)),
      enabled_(enabled),
      out_(out),
      terminal_(terminal),
      interval_(terminal ? std::min<Clock::duration>(interval, 200ms) : interval),
      delay_(delay),
      start_(Clock::now()),
      last_(start_) {}

double Progress::secondsLeft(double fraction, double elapsed_s) {
  if (!(fraction > 0.0)) return -1.0;
  return elapsed_s * (1.0 - std::min(fraction, 1.0)) / std::min(fraction, 1.0);
}

std::string Progress::formatDuration(double seconds) {
  const long s = std::lround(std::max(0.0, seconds));
  char text[40];
  if (s < 60) std::snprintf(text, sizeof text, "%ld s", s);
  else if (s < 3600) std::snprintf(text, sizeof text, "%ld min %02ld s", s / 60, s % 60);
  else std::snprintf(text, sizeof text, "%ld h %02ld min", s / 3600, (s / 60) % 60);
  return text;
}

void Progress::update(double fraction, const std::string& detail) {
  update(fraction, secondsLeft(std::clamp(fraction, 0.0, 1.0), std::chrono::duration<double>(Clock::now() - start_).count()), detail);
}

void Progress::update(double fraction, double left, const std::string& detail) {
  if (!enabled_ || finished_ || fraction >= 1.0) return;  // the end is finish()'s line
  const auto now = Clock::now();
  if (now - start_ < delay_ || now - last_ < interval_) return;
  last_ = now;
  fraction = std::clamp(fraction, 0.0, 1.0);
  char percent[16];
  std::snprintf(percent, sizeof percent, "%.0f %%", 100.0 * fraction);
  std::string line = phase_ + ": " + percent;
  if (!detail.empty()) line += " (" + detail + ")";
  line += left < 0.0 ? " ETA unknown" : " ETA " + formatDuration(left);
  if (terminal_) out_ << "\r\033[K" << line << std::flush;
  else out_ << line << std::endl;
  printed_ = true;
}

void Progress::finish(const std::string& detail) {
  if (!enabled_ || finished_) return;
  finished_ = true;
  const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
  if (!printed_ && elapsed < std::chrono::duration<double>(delay_).count()) return;
  char took[32];
  std::snprintf(took, sizeof took, "%.1f s", elapsed);
  std::string line = phase_ + ": done in " + took;
  if (!detail.empty()) line += " (" + detail + ")";
  if (terminal_) out_ << "\r\033[K";
  out_ << line << std::endl;
}

std::function<void(const std::string&, double, const std::string&)> depositionProgress(bool enabled) {
  auto lines = std::make_shared<std::map<std::string, Progress>>();
  return [lines, enabled](const std::string& name, double fraction, const std::string& stage_line) {
    if (!enabled) return;
    const std::string phase = "deposition of the soil of " + name;
    Progress& progress = lines->try_emplace(name, phase).first->second;
    if (!stage_line.empty()) std::cerr << phase << ": " << stage_line << std::endl;
    if (fraction >= 1)
      progress.finish();
    else
      progress.update(fraction);
  };
}

}  // namespace demfem::cli
