// The thread team of the built-in DEM: every thread runs the body once per run, a barrier orders
// the threads' writes, and a thread that sleeps past the spin (as one that lost its core) is
// waited for, not lost.
#include "demfem/backends/builtin/thread_team.hpp"

#include <catch2/catch.hpp>

#include <chrono>
#include <thread>
#include <vector>

using demfem::builtin::ThreadTeam;

TEST_CASE("a team runs its body on every thread and its barrier makes each thread's writes visible", "[builtin]") {
  for (const int size : {1, 2, 3}) {
    INFO("threads " << size);
    ThreadTeam team(size);
    std::vector<long> slot(size, 0), seen(size, 0);
    for (long run = 1; run <= 2000; ++run) {
      team.run([&](int tid) {
        slot[tid] = run * (tid + 1);
        team.barrier();
        long sum = 0;
        for (int t = 0; t < size; ++t) sum += slot[t];
        seen[tid] = sum;
        team.barrier();
      });
      for (int t = 0; t < size; ++t) REQUIRE(seen[t] == run * size * (size + 1) / 2);
    }
  }
}

TEST_CASE("a team waits for a thread that sleeps past the spin, at a barrier and between runs", "[builtin]") {
  ThreadTeam team(3);
  std::vector<int> count(3, 0);
  for (int run = 0; run < 20; ++run) {
    team.run([&](int tid) {
      if (tid == run % 3) std::this_thread::sleep_for(std::chrono::milliseconds(3));
      team.barrier();
      ++count[tid];
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(1));  // the workers fall asleep between runs
  }
  for (const int c : count) CHECK(c == 20);
  ThreadTeam copy = team;  // a copy has threads of its own
  CHECK(copy.size() == 3);
  copy.run([&](int tid) { ++count[tid]; });
  for (const int c : count) CHECK(c == 21);
}
