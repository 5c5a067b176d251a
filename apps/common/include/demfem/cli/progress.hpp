// Progress of a long phase of a demfem command, on standard error only (standard output carries
// results). Every phase longer than a few seconds reports through one of these.
//
// Output: a line "PHASE: 42 % (DETAIL) ETA 12 s" at most every `interval` while the
// fraction grows (default 5 s), and "PHASE: done in 20.1 s (DETAIL)" from finish(). On a terminal the line is
// redrawn in place (at most every 0.2 s) instead. The time left is the elapsed time scaled by the
// fraction still to do (a constant-rate estimate). Nothing is printed during the first `delay`
// (default 1 s), and finish() prints only when the phase took longer than that or printed before,
// so phases that end quickly stay silent. A fraction of 1 prints nothing: the end is finish()'s.
#pragma once

#include <chrono>
#include <functional>
#include <ostream>
#include <string>

namespace demfem::cli {

class Progress {
 public:
  using Clock = std::chrono::steady_clock;

  // `enabled` false: prints nothing (--quiet). `out` is where lines go (standard error by default).
  explicit Progress(std::string phase, bool enabled = true);
  Progress(std::string phase, bool enabled, std::ostream& out, bool terminal, Clock::duration interval, Clock::duration delay);

  // Reports `fraction` (clamped to [0, 1]) done; `detail` is shown in brackets when not empty.
  void update(double fraction, const std::string& detail = "");
  // The same with the time left known to the caller (seconds, negative: unknown), for phases whose
  // fraction done is not all this call's work (runs resumed from checkpoints).
  void update(double fraction, double seconds_left, const std::string& detail);
  // Ends the phase: prints the done line if anything was printed or the phase took longer than
  // `delay`.
  void finish(const std::string& detail = "");

  // Seconds left at `fraction` done after `elapsed_s` (constant rate); negative when unknown.
  static double secondsLeft(double fraction, double elapsed_s);
  // "12 s", "3 min 05 s", "1 h 02 min".
  static std::string formatDuration(double seconds);

 private:
  std::string phase_;
  bool enabled_;
  std::ostream& out_;
  bool terminal_;
  Clock::duration interval_, delay_;
  Clock::time_point start_, last_;
  bool printed_ = false;
  bool finished_ = false;
};

// The progress of the soil depositions a command waits for, as a callback of the campaign
// library's DepositionProgress: one Progress per study ("deposition of the soil of NAME"), ended
// when its fraction reaches 1, and the deposition's stage lines printed as they come. `enabled`
// false: prints nothing. Copies of the callback share the lines.
std::function<void(const std::string& study_name, double fraction, const std::string& stage_line)> depositionProgress(bool enabled);

}  // namespace demfem::cli
