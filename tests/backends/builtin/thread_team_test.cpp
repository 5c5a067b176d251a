// The thread team of the built-in DEM: every phase runs each part exactly once and makes its writes
// visible; a part is run by whichever thread claims it, so a thread stuck in one part does not keep
// the others from the rest; threads asleep between phases are woken, not lost.
#include "demfem/backends/builtin/thread_team.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

using demfem::builtin::TeamModeChoice;
using demfem::builtin::ThreadTeam;

TEST_CASE("a team runs every part once per phase and each phase sees the writes of the one before", "[builtin]") {
  for (const int threads : {1, 2, 3}) {
    for (const int parts : {1, 2, 5}) {
      INFO("threads " << threads << ", parts " << parts);
      ThreadTeam team(threads, parts);
      std::vector<long> slot(parts, 0), seen(parts, 0);
      std::vector<std::atomic<int>> runs(parts);
      for (long phase = 1; phase <= 1000; ++phase) {
        team.forEachPart([&](int part) {
          slot[part] = phase * (part + 1);
          runs[part].fetch_add(1);
        });
        team.forEachPart([&](int part) {
          long sum = 0;
          for (int p = 0; p < parts; ++p) sum += slot[p];
          seen[part] = sum;
        });
        for (int p = 0; p < parts; ++p) REQUIRE(seen[p] == phase * parts * (parts + 1) / 2);
      }
      for (int p = 0; p < parts; ++p) CHECK(runs[p].load() == 1000);
    }
  }
}

// A worker that holds a part stands for a thread that lost its core in the middle of its work: it
// waits until every other part of the phase is done, which only the caller can do, so a team that
// tied parts to threads would never finish the phase.
TEST_CASE("a thread stuck in one part leaves the other parts of the phase to the threads that can run them",
          "[builtin]") {
  constexpr int kParts = 4;
  ThreadTeam team(2, kParts);
  const auto caller = std::this_thread::get_id();
  for (int phase = 0; phase < 200; ++phase) {
    std::atomic<int> done{0};
    std::atomic<int> by_caller{0};
    std::atomic<bool> timed_out{false};
    team.forEachPart([&](int) {
      if (std::this_thread::get_id() == caller) {
        by_caller.fetch_add(1);
      } else {
        const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (done.load() < kParts - 1)
          if (std::chrono::steady_clock::now() > give_up) {
            timed_out = true;
            break;
          }
      }
      done.fetch_add(1);
    });
    REQUIRE_FALSE(timed_out.load());
    REQUIRE(done.load() == kParts);
    REQUIRE(by_caller.load() >= kParts - 1);
    if (phase % 20 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // workers fall asleep
  }
}

TEST_CASE("a team waits for a part that sleeps past the spin and wakes threads asleep between phases", "[builtin]") {
  ThreadTeam team(3, 3);
  std::vector<int> count(3, 0);
  for (int phase = 0; phase < 20; ++phase) {
    team.forEachPart([&](int part) {
      if (part == phase % 3) std::this_thread::sleep_for(std::chrono::milliseconds(3));
      ++count[part];
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(1));  // the workers fall asleep between phases
  }
  for (const int c : count) CHECK(c == 20);
  ThreadTeam copy = team;  // a copy has threads of its own
  CHECK(copy.size() == 3);
  CHECK(copy.parts() == 3);
  copy.forEachPart([&](int part) { ++count[part]; });
  for (const int c : count) CHECK(c == 21);
}

// A worker that takes 2 ms for any part it runs stands for threads whose cores other processes
// hold: the caller alone finishes a phase in microseconds, so after its first probes the team
// leaves the phases to the caller, and its later probes of the whole team stop at their first phase.
TEST_CASE("a team whose other threads slow the phases down leaves them to the caller", "[builtin]") {
  constexpr int kPhases = 9000;  // two probes of the team: 128 + 128 + 4096, 128 + 1 + 8192
  ThreadTeam team(2, 2);
  const auto caller = std::this_thread::get_id();
  std::atomic<int> by_worker{0};
  std::vector<int> runs(2, 0);
  for (int phase = 0; phase < kPhases; ++phase)
    team.forEachPart([&](int part) {
      if (std::this_thread::get_id() != caller) {
        by_worker.fetch_add(1);
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
      ++runs[part];
    });
  CHECK(runs[0] == kPhases);
  CHECK(runs[1] == kPhases);
  // Probes of the whole team: the first 128 phases, then after 128 + 4096 alone one until the
  // worker's first part (its 2 ms are longer than the caller's 128 phases; team phases whose parts
  // the caller took both are fast and do not end it). At most 128 + 1 worker parts, where probes of
  // 128 phases each give the worker about 256; the bound leaves room for a caller preempted during
  // its own probe.
  CHECK(by_worker.load() <= 160);
  CHECK(team.phasesAlone() >= kPhases - 3 * 128);
}

namespace {

// Phases run by a TeamModeChoice whose phases take `team` by the whole team and `alone` by the
// caller alone, a team phase telling `estimate` as what the caller alone would have taken (zero:
// none); returns the phases the team ran.
long teamPhases(TeamModeChoice& choice, long phases, std::chrono::nanoseconds team, std::chrono::nanoseconds alone,
                bool busy = false, std::chrono::nanoseconds estimate = std::chrono::nanoseconds{0}) {
  long by_team = 0;
  for (long k = 0; k < phases; ++k) {
    const bool caller_alone = choice.alone();
    by_team += !caller_alone;
    choice.record(caller_alone ? alone : team, busy, caller_alone ? std::chrono::nanoseconds{0} : estimate);
  }
  return by_team;
}

}  // namespace

TEST_CASE("the team's choice runs the faster way, cuts the losing probe short and probes a winner ever more rarely",
          "[builtin]") {
  using std::chrono::microseconds;
  constexpr long kProbe = TeamModeChoice::kProbePhases, kRun = TeamModeChoice::kRunPhases;
  SECTION("beside a busy process: the team's later probes stop at their first phase") {
    TeamModeChoice choice;
    // The team first (128), the caller alone wins (128 + 4096); then the caller alone is the
    // incumbent (128) and the team's probe loses at its first 2 ms phase, before stretches of
    // 2, 4 and 8 times 4096 phases.
    const long cycle1 = kProbe + kProbe + kRun;
    CHECK(teamPhases(choice, cycle1, microseconds(2000), microseconds(10)) == kProbe);
    long alone = cycle1 - kProbe;
    for (const long stretch : {2 * kRun, 4 * kRun, 8 * kRun}) {
      CHECK(teamPhases(choice, kProbe + 1 + stretch, microseconds(2000), microseconds(10)) == 1);
      alone += kProbe + stretch;
    }
    CHECK(choice.phasesAlone() == alone);
  }
  SECTION("on a quiet machine: the caller's probe stops once it is the slower; the stretches double up to 16 x 4096") {
    TeamModeChoice choice;
    // Team 6 us, alone 10 us a phase: the team's probe takes 768 us, the caller's loses at its 77th
    // phase (770 us).
    const long alone_probe = 77;
    for (const long stretch : {kRun, 2 * kRun, 4 * kRun, 8 * kRun, 16 * kRun, 16 * kRun}) {
      CHECK(teamPhases(choice, kProbe + alone_probe + stretch, microseconds(6), microseconds(10)) == kProbe + stretch);
    }
    CHECK(teamPhases(choice, kProbe, microseconds(6), microseconds(10)) == kProbe);
    CHECK(choice.alone());  // the next probe began after a stretch of 16 x 4096, not 32
    CHECK(choice.phasesAlone() == 6 * alone_probe);
  }
  SECTION("a thread preempted during a long stretch ends it after 4096 phases") {
    TeamModeChoice choice;
    const long alone_probe = 77;
    CHECK(teamPhases(choice, kProbe + alone_probe + kRun, microseconds(6), microseconds(10)) == kProbe + kRun);
    CHECK(teamPhases(choice, kProbe + alone_probe, microseconds(6), microseconds(10)) == kProbe);
    CHECK(teamPhases(choice, kRun - 1, microseconds(6), microseconds(10)) == kRun - 1);  // of 2 x 4096
    CHECK(teamPhases(choice, 1, microseconds(6), microseconds(10), true) == 1);
    CHECK(teamPhases(choice, kProbe, microseconds(6), microseconds(10)) == kProbe);
    CHECK(choice.alone());  // the probe after the cut stretch
  }
  SECTION("a team that clearly wins on a quiet machine never has the caller alone probed") {
    TeamModeChoice choice;
    // Team 6 us a phase, and by the caller's own parts 12 us alone (6 / 12 <= 4/5): the team's
    // probes count as won, so its stretches still double.
    for (const long stretch : {kRun, 2 * kRun, 4 * kRun, 8 * kRun, 16 * kRun, 16 * kRun}) {
      CHECK(teamPhases(choice, kProbe + stretch, microseconds(6), microseconds(10), false, microseconds(12)) ==
            kProbe + stretch);
    }
    CHECK(choice.phasesAlone() == 0);
    // The next team's probe begins here: won by less than 1/5, it is followed by the caller's.
    CHECK(teamPhases(choice, kProbe, microseconds(6), microseconds(10), false, microseconds(7)) == kProbe);
    CHECK(choice.alone());
  }
  SECTION("the caller alone is probed when the team's win is not clear, busy or without an estimate") {
    const long alone_probe = 77;  // as on the quiet machine above: the caller's probe loses at its 77th phase
    {
      TeamModeChoice choice;  // 6 us against an estimate of 7 us: above 4/5
      CHECK(teamPhases(choice, kProbe + alone_probe + kRun, microseconds(6), microseconds(10), false, microseconds(7)) ==
            kProbe + kRun);
      CHECK(choice.phasesAlone() == alone_probe);
    }
    {
      TeamModeChoice choice;  // one busy phase in the team's probe
      CHECK(teamPhases(choice, kProbe - 1, microseconds(6), microseconds(10), false, microseconds(12)) == kProbe - 1);
      CHECK(teamPhases(choice, 1, microseconds(6), microseconds(10), true, microseconds(12)) == 1);
      CHECK(choice.alone());
    }
    {
      TeamModeChoice choice;  // one phase whose parts the caller did not run
      CHECK(teamPhases(choice, 1, microseconds(6), microseconds(10), false, microseconds(0)) == 1);
      CHECK(teamPhases(choice, kProbe - 1, microseconds(6), microseconds(10), false, microseconds(12)) == kProbe - 1);
      CHECK(choice.alone());
    }
  }
  SECTION("a challenger that is faster over its whole probe takes over") {
    TeamModeChoice choice;
    const long cycle = 2 * kProbe + kRun;
    CHECK(teamPhases(choice, cycle, microseconds(10), microseconds(9)) == kProbe);
    CHECK(choice.alone());
  }
}
