// The threads of one built-in DEM simulation (docs/builtin-dem.md, "Threads on a shared
// machine"). A step is a sequence of phases; a phase is a fixed number of parts (the partitions of
// the particles) that any thread of the team may run. The caller is one of the threads; the others
// are kept from phase to phase and sleep when there is nothing to run.
//
// Contract
// - forEachPart(body) calls body(part) exactly once for each part in [0, parts()) and returns when
//   every call has returned; memory written by every call is then visible to the caller, and memory
//   the caller wrote before the call is visible to every call. Which thread runs a part is not
//   fixed: each thread claims its home part first (the same every phase, for the cache) and then
//   any part still unclaimed, so a thread that lost its core to another process delays no one
//   unless it holds a part, and the caller runs every part itself if the other threads never get
//   a core. A part's result must therefore depend on the part only,
//   never on the thread that runs it (so results are the same bit for bit whichever thread it was).
// - The body must not throw (a throw terminates, as in an OpenMP region): the loops record
//   failures and the caller raises them after the phase. forEachPart is called from one thread
//   only (the team's owner), never from inside a body.
// - Wait policy, for a machine shared with other processes: a waiting thread spins for at most
//   200 microseconds, or 10 once a thread of the team has been preempted lately (the machine is
//   busy), then sleeps in the kernel until woken, giving its core to whoever can use it.
// - Team or caller alone: the team times a probe of kProbePhases phases run the way it runs now
//   and one run the other way (by the whole team, or by the caller alone with the other threads
//   asleep), the second cut short once it is the slower, and runs a stretch of phases the faster
//   way, then probes again: 4,096 phases after a change of way, twice the last stretch (up to
//   65,536) while the same way keeps winning, 4,096 again once a thread of the team is preempted
//   (TeamModeChoice). The caller alone is not probed while the team clearly wins without it: no
//   thread of the team preempted, and the team's phases at most 4/5 of what the caller's own
//   parts, at the caller's speed, say it would take alone. On a machine whose other cores are
//   taken by other processes the caller alone is the faster, and the team then runs at one
//   thread's speed instead of waiting for threads that have no core. The numbers do not change
//   (see above).
// - Copying a team makes a new team of the same size (a simulation's copy gets its own threads).
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace demfem::builtin {

// Involuntary context switches of the calling thread so far (0 where the system does not say).
long involuntaryContextSwitches();

// Which way a thread team runs its next phase (ThreadTeam's contract, "Team or caller alone"):
// record() takes each phase's wall time, alone() says whether the next phase is the caller's alone.
// The way running now (the incumbent; the whole team at first) is timed over kProbePhases phases,
// then the other way (the challenger) over as many, stopped as soon as it has taken longer in all
// than the incumbent's probe: it has lost, and a challenger whose threads have no core costs one
// slow phase, not a probe's worth. The faster way then runs the next stretch of phases: kRunPhases
// after a change of way, twice the last stretch (at most kMaxRunPhases) after each probe the
// incumbent won, so that a choice that keeps winning is probed ever more rarely. A phase recorded
// as busy (a thread of the team was preempted lately: the machine changed) ends a stretch longer
// than kRunPhases once kRunPhases of it have run.
//
// The caller alone costs a probe's worth of slow phases even when it loses by half, so it is not
// probed while the team's probe shows that the team clearly wins: each of its phases came with an
// estimate of the caller alone (the caller's own parts' time scaled to all parts, at the caller's
// speed, not that of threads that may have lost their core), none was busy, and the phases took at
// most kClearWin of the estimates in all. The team's probe then counts as won.
class TeamModeChoice {
 public:
  static constexpr int kProbePhases = 128, kRunPhases = 4096, kMaxRunPhases = 16 * kRunPhases;

  bool alone() const {
    switch (stage_) {
      case Stage::ProbeIncumbent:
      case Stage::Run: return run_alone_;
      case Stage::ProbeChallenger: return !run_alone_;
    }
    return run_alone_;
  }

  static constexpr double kClearWin = 0.8;

  // `alone_estimate`: for a phase of the whole team, what it would have taken the caller alone
  // (zero if the caller ran none of its parts, and for a phase of the caller alone).
  void record(std::chrono::nanoseconds phase, bool busy, std::chrono::nanoseconds alone_estimate) {
    ++phases_all_;
    phases_alone_ += alone();
    spent_ += phase;
    ++phases_;
    switch (stage_) {
      case Stage::ProbeIncumbent:
        clear_win_ = clear_win_ && !busy && alone_estimate.count() > 0;
        estimate_ += alone_estimate;
        if (phases_ < kProbePhases) return;
        if (!run_alone_ && clear_win_ && static_cast<double>(spent_.count()) <= kClearWin * static_cast<double>(estimate_.count())) {
          run_phases_ = std::min(2 * run_phases_, kMaxRunPhases);
          stage_ = Stage::Run;
          break;
        }
        incumbent_ = spent_;
        stage_ = Stage::ProbeChallenger;
        break;
      case Stage::ProbeChallenger:
        if (spent_ <= incumbent_ && phases_ < kProbePhases) return;
        if (spent_ < incumbent_) {
          run_alone_ = !run_alone_;
          run_phases_ = kRunPhases;
        } else {
          run_phases_ = std::min(2 * run_phases_, kMaxRunPhases);
        }
        stage_ = Stage::Run;
        break;
      case Stage::Run:
        if (busy) run_phases_ = kRunPhases;
        if (phases_ < run_phases_) return;
        stage_ = Stage::ProbeIncumbent;
        break;
    }
    phases_ = 0;
    spent_ = estimate_ = std::chrono::nanoseconds{0};
    clear_win_ = true;
  }

  long phases() const { return phases_all_; }
  long phasesAlone() const { return phases_alone_; }

 private:
  enum class Stage { ProbeIncumbent, ProbeChallenger, Run };
  Stage stage_ = Stage::ProbeIncumbent;
  bool run_alone_ = false;  // the incumbent
  int phases_ = 0;          // of the current stage
  int run_phases_ = kRunPhases / 2;  // of the last stretch (the first is kRunPhases)
  long phases_all_ = 0, phases_alone_ = 0;
  std::chrono::nanoseconds spent_{0}, incumbent_{0};
  std::chrono::nanoseconds estimate_{0};  // of the caller alone, over the team's probe so far
  bool clear_win_ = true;                 // every phase of that probe had one and was not busy
};

class ThreadTeam {
 public:
  // `threads` threads sharing `parts` parts per phase (each at least 1).
  ThreadTeam(int threads, int parts) : size_(threads < 1 ? 1 : threads), parts_(parts < 1 ? 1 : parts) { start(); }
  ThreadTeam(const ThreadTeam& other) : size_(other.size_), parts_(other.parts_) { start(); }
  ThreadTeam& operator=(const ThreadTeam& other) {
    if (this == &other) return *this;
    stop();
    size_ = other.size_;
    parts_ = other.parts_;
    start();
    return *this;
  }
  ~ThreadTeam() { stop(); }

  int size() const { return size_; }
  int parts() const { return parts_; }

  void forEachPart(const std::function<void(int)>& body) {
    if (size_ == 1) {
      for (int part = 0; part < parts_; ++part) body(part);
      return;
    }
    const auto began = std::chrono::steady_clock::now();
    std::chrono::nanoseconds alone_estimate{0};
    if (choice_.alone()) {
      for (int part = 0; part < parts_; ++part) body(part);
    } else {
      alone_estimate = runTeamPhase(body);
    }
    choice_.record(std::chrono::steady_clock::now() - began, machineBusy(), alone_estimate);
  }

  // Phases run so far with more than one thread, and those of them the caller ran alone (for
  // tests and benchmarks).
  long phases() const { return choice_.phases(); }
  long phasesAlone() const { return choice_.phasesAlone(); }

 private:
  // Runs a phase by the whole team; returns what the caller alone would have taken for it at the
  // speed it ran its own parts (zero if it ran none).
  std::chrono::nanoseconds runTeamPhase(const std::function<void(int)>& body) {
    body_ = &body;
    done_.store(0, std::memory_order_relaxed);
    const std::uint64_t phase = phase_.load(std::memory_order_relaxed) + 1;
    phase_.store(phase, std::memory_order_release);  // publishes body_ and done_ = 0
    wake();
    const auto own_began = std::chrono::steady_clock::now();
    const int own = runParts(phase, 0);
    const auto own_time = std::chrono::steady_clock::now() - own_began;
    waitUntil([&] { return done_.load(std::memory_order_acquire) == static_cast<std::uint32_t>(parts_); }, 0);
    return own > 0 ? own_time * parts_ / own : std::chrono::nanoseconds{0};
  }

  static constexpr std::chrono::microseconds kSpinQuiet{200}, kSpinBusy{10};
  static constexpr int kCheckEvery = 64;    // waits between two looks at the preemption count
  static constexpr long kBusySwitches = 4;  // preemptions within them that mark the machine busy
  static constexpr int kBusyChecks = 4;     // a busy mark lasts this many looks (a busy thread
                                            // sleeps more and is preempted less)
  struct alignas(64) Preemptions {  // a cache line each: every wait counts
    long waits = 0, switches = 0;
    int busy_left = 0;
  };

  static void pause() {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#else
    std::this_thread::yield();
#endif
  }

  // Claims and runs the parts of `phase` that are left, its home part (the one thread `thread`
  // ran last phase too, whose particles are still in its core's cache) first. A claim is one
  // compare-and-swap of the part's last phase from phase - 1 to phase, so a thread that wakes late
  // for a phase already finished claims nothing; and the phase a thread holds a part of cannot
  // finish, nor its body_ be replaced, before that part is done. Returns the number of parts run.
  int runParts(std::uint64_t phase, int thread) {
    const int home = static_cast<int>(static_cast<long>(thread) * parts_ / size_);
    int ran = 0;
    for (int k = 0; k < parts_; ++k) {
      const int part = (home + k) % parts_;
      std::uint64_t expected = phase - 1;
      if (!claimed_[part].compare_exchange_strong(expected, phase, std::memory_order_acq_rel)) continue;
      (*body_)(part);
      ++ran;
      if (done_.fetch_add(1, std::memory_order_acq_rel) + 1 == static_cast<std::uint32_t>(parts_)) wake();
    }
    return ran;
  }

  // Spin, then sleep until `ready()` (whoever makes it true stores, then calls wake()). `who` is
  // the waiting thread (0 the caller).
  template <class Ready>
  void waitUntil(Ready ready, int who) {
    notePreemptions(who);
    const auto until = std::chrono::steady_clock::now() + spinBudget();
    for (int k = 0;; ++k) {
      if (ready()) return;
      pause();
      if (k % 16 == 15 && std::chrono::steady_clock::now() > until) break;
    }
    std::unique_lock<std::mutex> lock(mutex_);
    wake_.wait(lock, ready);
  }

  // How long a waiting thread spins before it sleeps. A sleeping thread takes tens of microseconds
  // to wake, a large part of a phase on a quiet machine (2 threads on the paper bin, 2026-12-02:
  // 1.52-1.60x of 1 thread with a 10 microsecond spin, 1.84x with 200); on a busy one a spinning
  // thread takes the core its partner needs (beside one busy process: 0.83x with 200, 1.02-1.10x
  // with 10). A thread preempted at least kBusySwitches times within kCheckEvery waits marks the
  // machine busy for kBusyChecks looks (measured: about 1 preemption per 64 waits when quiet, 12
  // beside a busy process).
  std::chrono::microseconds spinBudget() const { return machineBusy() ? kSpinBusy : kSpinQuiet; }
  bool machineBusy() const {
    for (const auto& b : busy_)
      if (b.load(std::memory_order_relaxed)) return true;
    return false;
  }
  // The first wait only takes the count to start from: the thread's count since it began (the
  // caller's may be long) says nothing about the machine now.
  void notePreemptions(int who) {
    Preemptions& p = preemptions_[static_cast<std::size_t>(who)];
    if (p.waits++ % kCheckEvery != 0) return;
    const long now = involuntaryContextSwitches();
    if (p.waits > 1) {
      if (now - p.switches >= kBusySwitches)
        p.busy_left = kBusyChecks;
      else if (p.busy_left > 0)
        --p.busy_left;
      busy_[static_cast<std::size_t>(who)].store(p.busy_left > 0, std::memory_order_relaxed);
    }
    p.switches = now;
  }

  void wake() {
    { std::lock_guard<std::mutex> lock(mutex_); }  // a waiter is either before its check or asleep
    wake_.notify_all();
  }

  void start() {
    choice_ = TeamModeChoice{};
    stopping_.store(false);
    phase_.store(0);
    claimed_ = std::vector<std::atomic<std::uint64_t>>(static_cast<std::size_t>(parts_));
    busy_ = std::vector<std::atomic<bool>>(static_cast<std::size_t>(size_));
    preemptions_.assign(static_cast<std::size_t>(size_), Preemptions{});
    for (int w = 1; w < size_; ++w)
      workers_.emplace_back([this, w] {
        std::uint64_t seen = 0;
        for (;;) {
          waitUntil(
              [&] { return stopping_.load(std::memory_order_acquire) || phase_.load(std::memory_order_acquire) != seen; },
              w);
          if (stopping_.load(std::memory_order_acquire)) return;
          seen = phase_.load(std::memory_order_acquire);
          runParts(seen, w);
        }
      });
  }

  void stop() {
    if (workers_.empty()) return;
    stopping_.store(true, std::memory_order_release);
    wake();
    for (auto& w : workers_) w.join();
    workers_.clear();
  }

  int size_, parts_;
  std::vector<std::thread> workers_;
  const std::function<void(int)>* body_ = nullptr;
  std::atomic<std::uint64_t> phase_{0};            // the phase being run (numbered from 1)
  std::vector<std::atomic<std::uint64_t>> claimed_;  // per part: the last phase that claimed it
  std::atomic<std::uint32_t> done_{0};             // parts of the current phase that have returned
  std::vector<std::atomic<bool>> busy_;             // per thread: it was preempted lately
  std::vector<Preemptions> preemptions_;            // per thread, its own only
  std::atomic<bool> stopping_{false};
  TeamModeChoice choice_;  // the caller's only
  std::mutex mutex_;
  std::condition_variable wake_;
};

}  // namespace demfem::builtin
