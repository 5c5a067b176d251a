// Wall and processor time of the campaign benchmarks (docs/calibration.md, docs/diagnosis.md).
// Processor time is this process' user + system time over all its threads plus that of its waited-for
// child processes (e.g. LIGGGHTS runs started by the fixture), in seconds. Both throw
// std::runtime_error when the system cannot tell.
#pragma once

#include <sys/resource.h>

#include <chrono>
#include <cstdlib>
#include <stdexcept>

namespace demfem::bench {

using Clock = std::chrono::steady_clock;

inline double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

inline double cpuSeconds() {
  const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  double total = 0;
  for (int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
    rusage u{};
    if (getrusage(who, &u) != 0) throw std::runtime_error("getrusage failed: no processor time");
    total += seconds(u.ru_utime) + seconds(u.ru_stime);
  }
  return total;
}

// The one-minute load average of the machine (other processes share the cores).
inline double loadAverage() {
  double load[1];
  if (getloadavg(load, 1) != 1) throw std::runtime_error("getloadavg failed: no load average");
  return load[0];
}

}  // namespace demfem::bench
