// The thread team of the built-in DEM: every phase runs each part exactly once and makes its writes
// visible; a part is run by whichever thread claims it, so a thread stuck in one part does not keep
// the others from the rest; threads asleep between phases are woken, not lost.
#include "demfem/backends/builtin/thread_team.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

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
// leaves the phases to the caller, and only its later probes of the whole team reach the worker.
TEST_CASE("a team whose other threads slow the phases down leaves them to the caller", "[builtin]") {
  constexpr int kPhases = 3000;
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
  // Probes of the whole team: the first 128 phases, then 128 after each 4096 + 128 alone: at most
  // 128 worker parts here; the caller ran everything else alone.
  CHECK(by_worker.load() <= 128);
  CHECK(team.phasesAlone() >= kPhases - 128);
}
